// SPDX-License-Identifier: GPL-3.0-or-later
// Texture particles placed on the surface (particles/placement.hpp): place_particles().
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "texsynth/particles/placement.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

std::vector<float> optional_floats(py::handle obj, py::ssize_t n, const char* name) {
  if (obj.is_none()) return {};
  FloatArray a = float_array(obj, name);
  require_shape(a, {n}, name);
  return std::vector<float>(a.data(), a.data() + a.size());
}

py::dict placement_stats(const texsynth::PlacementStats& s) {
  py::list classes;
  for (const auto& c : s.classes)
    classes.append(stats_dict("class", c.class_id, "placed", c.placed, "hidden", c.hidden, "thinned", c.thinned,
                              "filled", c.filled, "expected", c.expected, "rejected_overlap", c.rejected_overlap, "crowded", c.crowded,
                              "walls", c.walls, "excluded", c.excluded, "seeds", c.seeds, "reseeded", c.reseeded,
                              "reseed_rounds", c.reseed_rounds, "cap", c.cap, "capped", c.capped, "random", c.random));
  return stats_dict("classes", classes, "components", s.components, "walks", s.walks, "capped", s.capped, "seconds",
                    s.seconds);
}

}  // namespace

void bind_particles_place(py::module_& m) {
  m.attr("placement_origins") = py::make_tuple("seed", "propagated", "reseeded", "random_class", "filled");
  m.def(
      "place_particles",
      [](const texsynth::ParticleAnalysis& analysis, const texsynth::SurfaceWalkMesh& mesh, py::object directions,
         double sample_world_width, py::object classes, py::object output_classes, py::object vertex_scale, py::object face_density,
         py::object face_probability, py::object face_size, double size_jitter, py::object seed_triangles,
         py::object seed_barycentrics, uint64_t seed, int64_t max_particles, py::object cancel, py::object progress) {
        const py::ssize_t V = py::ssize_t(mesh.positions.size() / 3), T = py::ssize_t(mesh.triangles.size() / 3);
        texsynth::PlacementParams p;
        FloatArray dirs = float_array(directions, "directions");
        require_shape(dirs, {V, 3}, "directions");
        p.directions.assign(dirs.data(), dirs.data() + dirs.size());
        p.sample_world_width = sample_world_width;
        if (!classes.is_none()) {
          IntArray c = int_array(classes, "classes");
          require_shape(c, {-1}, "classes");
          p.classes.assign(c.data(), c.data() + c.size());
          if (p.classes.empty()) throw std::invalid_argument("classes must list at least one class, or be None");
        }
        if (!output_classes.is_none()) {
          IntArray c = int_array(output_classes, "output_classes");
          require_shape(c, {-1}, "output_classes");
          p.output_classes.assign(c.data(), c.data() + c.size());
          if (p.output_classes.empty())
            throw std::invalid_argument("output_classes must list at least one class, or be None");
        }
        p.vertex_scale = optional_floats(vertex_scale, V, "vertex_scale");
        p.face_density = optional_floats(face_density, T, "face_density");
        p.face_probability = optional_floats(face_probability, T, "face_probability");
        p.face_size = optional_floats(face_size, T, "face_size");
        p.size_jitter = size_jitter;
        if (seed_triangles.is_none() != seed_barycentrics.is_none())
          throw std::invalid_argument("seed_triangles and seed_barycentrics go together");
        if (!seed_triangles.is_none()) {
          IntArray t = int_array(seed_triangles, "seed_triangles");
          require_shape(t, {-1}, "seed_triangles");
          auto b = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(
              py::array::ensure(seed_barycentrics));
          if (!b) throw std::invalid_argument("seed_barycentrics must be numeric");
          require_shape(b, {t.shape(0), 2}, "seed_barycentrics");
          for (py::ssize_t i = 0; i < t.shape(0); ++i)
            p.seeds.push_back({t.data()[i], b.data()[2 * i], b.data()[2 * i + 1]});
        }
        p.seed = seed;
        p.max_particles = max_particles;
        p.cancel = cancel_flag(cancel);
        if (!progress.is_none()) cancel_flag(progress);  // a CancelToken or a ValueError
        p.progress = progress_slot(progress.is_none() ? cancel : progress);
        // Two tokens (cancel, progress), so not cancellable(): the flags are set above.
        texsynth::PlacedParticles r = without_gil([&] { return texsynth::place_particles(analysis, mesh, p); });
        const py::ssize_t n = py::ssize_t(r.size());
        py::dict out;
        out["class"] = to_numpy(std::move(r.class_id), {n});
        out["sprite"] = to_numpy(std::move(r.sprite), {n});
        out["parent"] = to_numpy(std::move(r.parent), {n});
        out["triangle"] = to_numpy(std::move(r.triangle), {n});
        out["barycentric"] = to_numpy(std::move(r.barycentric), {n, 2});
        out["position"] = to_numpy(std::move(r.position), {n, 3});
        out["normal"] = to_numpy(std::move(r.normal), {n, 3});
        out["sprite_axis"] = to_numpy(std::move(r.sprite_axis), {n, 3});
        out["pixel_size"] = to_numpy(std::move(r.pixel_size), {n});
        out["angle"] = to_numpy(std::move(r.angle), {n});
        out["origin"] = to_numpy(std::move(r.origin), {n});
        out["stats"] = placement_stats(r.stats);
        return out;
      },
      py::arg("analysis"), py::arg("walk_mesh"), py::arg("directions"), py::kw_only(), py::arg("sample_world_width"),
      py::arg("classes") = py::none(), py::arg("output_classes") = py::none(), py::arg("vertex_scale") = py::none(), py::arg("face_density") = py::none(),
      py::arg("face_probability") = py::none(), py::arg("face_size") = py::none(), py::arg("size_jitter") = 0.0,
      py::arg("seed_triangles") = py::none(), py::arg("seed_barycentrics") = py::none(), py::arg("seed") = 0,
      py::arg("max_particles") = 2000000, py::arg("cancel") = py::none(), py::arg("progress") = py::none(),
      "Places the analysis's particles on the mesh (§2.2-2.3): seeds per mesh component (seed_triangles / "
      "seed_barycentrics (S, 2), else nearest each component's area centroid), breadth-first propagation "
      "through the co-occurrence lists along normal sections, overlap rejection against every particle placed "
      "so far (other classes by the analysis's class_pairs), re-seeding, random classes by dart throwing, each "
      "class thinned to the sample's density when it holds more. directions (V, 3) per-vertex 'up' field; "
      "sample_world_width: world size of the sample's width; classes: processing order (None = every class with "
      "a complete particle, by count); output_classes: the classes whose rows are returned (None = all; the "
      "classes before them in the order are placed too, so the rows are those of the full run); vertex_scale (V,) > 0 multiplier (2 = features half as large); face_density / face_probability / "
      "face_size (T,) overrides; size_jitter 0..0.9. Returns dict of arrays, one row per output particle: class, "
      "sprite (source particle id), parent (row or -1), triangle, barycentric (n, 2) float64, position, normal, "
      "sprite_axis (n, 3) float32, pixel_size, angle (n,) float32, origin (n,) uint8 indexing placement_origins; "
      "and stats. ValueError on bad input; cancel: a CancelToken (Cancelled); progress: a CancelToken whose "
      "progress is updated (default: cancel's).");
}
