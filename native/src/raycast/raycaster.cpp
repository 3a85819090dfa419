// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/raycast/raycaster.hpp"

#include "texsynth/common/build_info.hpp"

#include "embree_compat.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

namespace texsynth {
namespace {

// One Embree device for the process: creating one costs milliseconds and holds thread state.
RTCDevice shared_device() {
  static std::once_flag once;
  static RTCDevice device = nullptr;
  std::call_once(once, [] { device = rtcNewDevice("verbose=0"); });
  if (!device) throw std::runtime_error("Embree device could not be created");
  return device;
}

void check_embree(RTCDevice device, const char* what) {
  RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE)
    throw std::runtime_error(std::string("Embree failed while ") + what + " (error " + std::to_string(int(e)) + ")");
}

constexpr int kCellBits = 21;  // 3 × 21 bits of cell coordinates packed in one 64-bit key
constexpr int64_t kMaxCell = (int64_t(1) << kCellBits) - 1;

}  // namespace

struct RayCaster::Impl {
  int32_t num_vertices = 0, num_polys = 0;
  std::vector<float> positions;            // num_vertices*3
  std::vector<int32_t> triangle_vertices;  // 3 per fan triangle
  std::vector<int32_t> triangle_poly;      // polygon of each triangle
  RTCScene scene = nullptr;

  // Uniform grid over vertices: vertices sorted by cell key; cell_keys[i] owns
  // grid_vertices[cell_start[i] .. cell_start[i+1]).
  float grid_origin[3] = {0, 0, 0};
  float cell_size = 1.f;
  std::vector<uint64_t> cell_keys;
  std::vector<int32_t> cell_start, grid_vertices;

  int64_t cell_coord(float p, int axis) const {
    double c = std::floor((double(p) - grid_origin[axis]) / cell_size);
    return int64_t(std::clamp(c, 0.0, double(kMaxCell)));
  }
  static uint64_t key(int64_t x, int64_t y, int64_t z) {
    return (uint64_t(x) << (2 * kCellBits)) | (uint64_t(y) << kCellBits) | uint64_t(z);
  }
  void build_grid();

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
  }
};

void RayCaster::Impl::build_grid() {
  if (num_vertices == 0) return;
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = positions[a];
  for (int32_t v = 0; v < num_vertices; ++v)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], positions[3 * size_t(v) + a]), hi[a] = std::max(hi[a], positions[3 * size_t(v) + a]);
  // Cell ≈ two mean edge lengths (a handful of vertices per occupied cell on a surface), never so
  // small that the coordinates overflow their bits.
  double edge_sum = 0;
  int64_t edges = 0;
  const int64_t nt = int64_t(triangle_poly.size());
  const int64_t stride = std::max<int64_t>(1, nt / 100000);
  for (int64_t t = 0; t < nt; t += stride)
    for (int k = 0; k < 3; ++k) {
      const float* a = &positions[3 * size_t(triangle_vertices[3 * t + k])];
      const float* b = &positions[3 * size_t(triangle_vertices[3 * t + (k + 1) % 3])];
      edge_sum += std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                            double(a[2] - b[2]) * (a[2] - b[2]));
      ++edges;
    }
  double extent = std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2], 1e-30});
  double h = edges ? 2.0 * edge_sum / double(edges) : extent;
  h = std::max({h, extent / double(kMaxCell - 1), 1e-30});
  cell_size = float(h);
  for (int a = 0; a < 3; ++a) grid_origin[a] = lo[a];

  std::vector<std::pair<uint64_t, int32_t>> keyed(num_vertices);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, num_vertices, 16384), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t v = r.begin(); v < r.end(); ++v) {
      const float* p = &positions[3 * size_t(v)];
      keyed[v] = {key(cell_coord(p[0], 0), cell_coord(p[1], 1), cell_coord(p[2], 2)), v};
    }
  });
  std::sort(keyed.begin(), keyed.end());
  grid_vertices.resize(num_vertices);
  for (int32_t i = 0; i < num_vertices; ++i) {
    grid_vertices[i] = keyed[i].second;
    if (i == 0 || keyed[i].first != keyed[i - 1].first) cell_keys.push_back(keyed[i].first), cell_start.push_back(i);
  }
  cell_start.push_back(num_vertices);
}

namespace {
// Debian's Embree asserts (aborts the process) on ray components beyond its FLT_LARGE (1.8e18);
// vertices are held to the same bound so hits and bounds stay in Embree's valid range.
constexpr float kMaxCoordinate = 1e18f;

bool usable(float x) { return std::isfinite(x) && std::fabs(x) <= kMaxCoordinate; }
}  // namespace

RayCaster::RayCaster(const PolyMeshInput& in) : impl_(std::make_unique<Impl>()) {
  if (in.num_vertices < 0 || in.num_corners < 0 || in.num_polys < 0)
    throw std::invalid_argument("mesh sizes must be non-negative");
  if ((in.num_vertices && !in.positions) || (in.num_corners && !in.corner_verts) ||
      (in.num_polys && (!in.poly_starts || !in.poly_sizes)))
    throw std::invalid_argument("mesh arrays must not be null");
  Impl& m = *impl_;
  m.num_vertices = in.num_vertices;
  m.num_polys = in.num_polys;
  m.positions.assign(in.positions, in.positions + 3 * size_t(in.num_vertices));
  for (size_t i = 0; i < m.positions.size(); ++i)
    if (!usable(m.positions[i]))
      throw std::invalid_argument("positions of vertex " + std::to_string(i / 3) +
                                  " are NaN, infinite or beyond +-1e18");
  for (int32_t c = 0; c < in.num_corners; ++c)
    if (in.corner_verts[c] < 0 || in.corner_verts[c] >= in.num_vertices)
      throw std::invalid_argument("corner_verts[" + std::to_string(c) + "] = " + std::to_string(in.corner_verts[c]) +
                                  " is not a vertex index (mesh has " + std::to_string(in.num_vertices) + " vertices)");
  int64_t triangles = 0;
  for (int32_t p = 0; p < in.num_polys; ++p) {
    const int64_t start = in.poly_starts[p], size = in.poly_sizes[p];
    if (size < 3 || start < 0 || start + size > in.num_corners)
      throw std::invalid_argument("polygon " + std::to_string(p) + " (start " + std::to_string(start) + ", size " +
                                  std::to_string(size) + ") is not a valid corner range of " +
                                  std::to_string(in.num_corners) + " corners");
    triangles += size - 2;
  }
  if (triangles > std::numeric_limits<int32_t>::max()) throw std::invalid_argument("mesh has too many triangles");
  m.triangle_vertices.reserve(3 * size_t(triangles));
  m.triangle_poly.reserve(size_t(triangles));
  for (int32_t p = 0; p < in.num_polys; ++p) {
    const int32_t* cv = in.corner_verts + in.poly_starts[p];
    for (int32_t k = 1; k + 1 < in.poly_sizes[p]; ++k) {
      m.triangle_vertices.insert(m.triangle_vertices.end(), {cv[0], cv[k], cv[k + 1]});
      m.triangle_poly.push_back(p);
    }
  }

  if (triangles > 0) {
    RTCDevice device = shared_device();
    m.scene = rtcNewScene(device);
    rtcSetSceneFlags(m.scene, RTC_SCENE_FLAG_ROBUST);
    // LOW = Morton-code builder: several times faster to build; a brush casts only a few rays per event.
    rtcSetSceneBuildQuality(m.scene, RTC_BUILD_QUALITY_LOW);
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Shared buffers: Embree reads our arrays (vertex buffers need 16 bytes of slack after the
    // last element: positions get one extra padding vertex).
    m.positions.resize(m.positions.size() + 4);
    rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0,
                               3 * sizeof(float), size_t(m.num_vertices));
    rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.triangle_vertices.data(), 0,
                               3 * sizeof(int32_t), size_t(triangles));
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(m.scene, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(m.scene);
    check_embree(device, "building the ray-cast BVH");
  }
  m.build_grid();
}

RayCaster::~RayCaster() = default;

int32_t RayCaster::num_vertices() const { return impl_->num_vertices; }
int32_t RayCaster::num_polys() const { return impl_->num_polys; }
int64_t RayCaster::num_triangles() const { return int64_t(impl_->triangle_poly.size()); }

std::vector<RayHit> RayCaster::cast(const float* origins, const float* directions, int64_t count, float t_near,
                                    float t_far) const {
  if (count < 0) throw std::invalid_argument("ray count must be non-negative");
  if (!std::isfinite(t_near) || std::isnan(t_far) || t_near < 0 || t_far < t_near)
    throw std::invalid_argument("need 0 <= t_near <= t_far (t_far may be +inf)");
  for (int64_t i = 0; i < 3 * count; ++i)
    if (!usable(origins[i]) || !usable(directions[i]))
      throw std::invalid_argument("ray " + std::to_string(i / 3) +
                                  " has a NaN, infinite or beyond +-1e18 origin or direction");
  std::vector<RayHit> hits(static_cast<size_t>(count));
  const Impl& m = *impl_;
  if (!m.scene) return hits;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, 64), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t i = r.begin(); i < r.end(); ++i) {
      const float* o = origins + 3 * i;
      const float* d = directions + 3 * i;
      if (d[0] == 0.f && d[1] == 0.f && d[2] == 0.f) continue;
      RTCRayHit rh{};
      rh.ray.org_x = o[0], rh.ray.org_y = o[1], rh.ray.org_z = o[2];
      rh.ray.dir_x = d[0], rh.ray.dir_y = d[1], rh.ray.dir_z = d[2];
      rh.ray.tnear = t_near;
      rh.ray.tfar = t_far;
      rh.ray.mask = 0xFFFFFFFFu;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      embree::intersect1(m.scene, rh);
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
      RayHit& h = hits[size_t(i)];
      const uint32_t t = rh.hit.primID;
      h.face = m.triangle_poly[t];
      for (int k = 0; k < 3; ++k) h.vertices[k] = m.triangle_vertices[3 * size_t(t) + k];
      // Embree: hit = (1-u-v)·v0 + u·v1 + v·v2.
      h.barycentrics[0] = 1.f - rh.hit.u - rh.hit.v;
      h.barycentrics[1] = rh.hit.u;
      h.barycentrics[2] = rh.hit.v;
      h.distance = rh.ray.tfar;
    }
  });
  return hits;
}

void RayCaster::vertices_within(const float point[3], float radius, std::vector<int32_t>& ids,
                                std::vector<float>& distances) const {
  if (!std::isfinite(point[0]) || !std::isfinite(point[1]) || !std::isfinite(point[2]))
    throw std::invalid_argument("query point is NaN or infinite");
  if (!std::isfinite(radius) || radius < 0) throw std::invalid_argument("radius must be finite and >= 0");
  ids.clear();
  distances.clear();
  const Impl& m = *impl_;
  const double r2 = double(radius) * radius;
  auto consider = [&](int32_t v) {
    const float* p = &m.positions[3 * size_t(v)];
    double dx = double(p[0]) - point[0], dy = double(p[1]) - point[1], dz = double(p[2]) - point[2];
    double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 <= r2) ids.push_back(v), distances.push_back(float(std::sqrt(d2)));
  };
  int64_t lo[3], hi[3];
  double cells = 1;
  for (int a = 0; a < 3; ++a) {
    lo[a] = m.cell_coord(point[a] - radius, a);
    hi[a] = m.cell_coord(point[a] + radius, a);
    cells *= double(hi[a] - lo[a] + 1);
  }
  if (cells > double(m.cell_keys.size())) {
    // Brush larger than the mesh's grid: a linear scan is cheaper than visiting empty cells.
    for (int32_t v = 0; v < m.num_vertices; ++v) consider(v);
    return;
  }
  for (int64_t x = lo[0]; x <= hi[0]; ++x)
    for (int64_t y = lo[1]; y <= hi[1]; ++y)
      for (int64_t z = lo[2]; z <= hi[2]; ++z) {
        const uint64_t k = Impl::key(x, y, z);
        auto it = std::lower_bound(m.cell_keys.begin(), m.cell_keys.end(), k);
        if (it == m.cell_keys.end() || *it != k) continue;
        const size_t c = size_t(it - m.cell_keys.begin());
        for (int32_t i = m.cell_start[c]; i < m.cell_start[c + 1]; ++i) consider(m.grid_vertices[i]);
      }
  // Sort by id so results are independent of the grid layout.
  std::vector<size_t> order(ids.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return ids[a] < ids[b]; });
  std::vector<int32_t> sorted_ids(ids.size());
  std::vector<float> sorted_distances(ids.size());
  for (size_t i = 0; i < order.size(); ++i) sorted_ids[i] = ids[order[i]], sorted_distances[i] = distances[order[i]];
  ids.swap(sorted_ids);
  distances.swap(sorted_distances);
}

int embree_runtime_version() {
  return int(rtcGetDeviceProperty(shared_device(), RTC_DEVICE_PROPERTY_VERSION));
}

std::string embree_library_file() { return file_holding(reinterpret_cast<const void*>(&rtcNewDevice)); }

}  // namespace texsynth
