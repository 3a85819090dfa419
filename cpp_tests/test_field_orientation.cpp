// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

#include "mesh_fixtures.hpp"
#include "texsynth/field/orientation_field.hpp"

using texsynth::FieldParams;
using texsynth::OrientationMode;

namespace {

double dot3(const float* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

void expect_unit_tangent(const texsynth::Mesh& m, const std::vector<float>& f) {
  ASSERT_EQ(f.size(), size_t(m.num_vertices) * 3);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    const float* u = &f[3 * v];
    const double n[3] = {m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]};
    EXPECT_NEAR(u[0] * u[0] + u[1] * u[1] + u[2] * u[2], 1.0, 1e-5) << "vertex " << v;
    EXPECT_NEAR(dot3(u, n), 0.0, 1e-5) << "vertex " << v;
  }
}

}  // namespace

TEST(FieldAxis, SphereVectorsAreTheProjectedAxisAwayFromPoles) {
  auto s = fixtures::uv_sphere(24, 32, 1.0);
  auto m = texsynth::build_mesh(s.input());
  FieldParams p;
  p.axis = {0.f, 0.f, 2.f};
  auto f = texsynth::compute_orientation_field(m, p);
  expect_unit_tangent(m, f);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    // Independent expectation: for a sphere the projected +z is the northward meridian direction.
    double x = s.positions[3 * v], y = s.positions[3 * v + 1], z = s.positions[3 * v + 2];
    double rxy = std::hypot(x, y);
    if (rxy < 0.2) continue;  // poles: only unit + tangent is required
    const double north[3] = {-z * x / rxy, -z * y / rxy, rxy};
    double len = std::sqrt(north[0] * north[0] + north[1] * north[1] + north[2] * north[2]);
    EXPECT_GT(dot3(&f[3 * v], north) / len, 0.995) << "vertex " << v;
  }
}

TEST(FieldAnchors, SingleAnchorOnFlatGridGivesConstantField) {
  auto g = fixtures::grid(12, 9, 0.3, true, 0.5);
  auto m = texsynth::build_mesh(g.input());
  FieldParams p;
  p.mode = OrientationMode::Anchors;
  p.anchor_vertices = {17};
  p.anchor_directions = {{0.6f, 0.8f, 0.5f}};  // normal component is projected away
  auto f = texsynth::compute_orientation_field(m, p);
  expect_unit_tangent(m, f);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    EXPECT_NEAR(f[3 * v], 0.6, 1e-5);
    EXPECT_NEAR(f[3 * v + 1], 0.8, 1e-5);
  }
}

TEST(FieldAnchors, ComponentWithoutAnchorFallsBackToAxis) {
  auto g = fixtures::grid(3, 3, 1.0, false);
  int32_t first_other = g.num_vertices();
  auto other = fixtures::grid(3, 3, 1.0, false);
  for (size_t i = 0; i < other.positions.size(); i += 3)
    g.add_vertex(other.positions[i] + 10, other.positions[i + 1], other.positions[i + 2]);
  for (size_t p = 0; p < other.poly_starts.size(); ++p) {
    std::vector<int32_t> poly;
    for (int i = 0; i < other.poly_sizes[p]; ++i) poly.push_back(first_other + other.corner_verts[other.poly_starts[p] + i]);
    g.add_poly(poly);
  }
  auto m = texsynth::build_mesh(g.input());
  FieldParams p;
  p.mode = OrientationMode::Anchors;
  p.axis = {0.f, 1.f, 0.f};
  p.anchor_vertices = {0};
  p.anchor_directions = {{1.f, 0.f, 0.f}};
  auto f = texsynth::compute_orientation_field(m, p);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    bool anchored = v < first_other;
    EXPECT_NEAR(f[3 * v], anchored ? 1.0 : 0.0, 1e-6) << v;
    EXPECT_NEAR(f[3 * v + 1], anchored ? 0.0 : 1.0, 1e-6) << v;
  }
}

TEST(FieldAnchors, SourcesPointAwayAndSinksToward) {
  const int n = 20;
  auto g = fixtures::grid(n, n, 1.0, true, 0.3);
  auto m = texsynth::build_mesh(g.input());
  const int32_t centre = (n / 2) * (n + 1) + n / 2;
  for (bool source : {true, false}) {
    FieldParams p;
    p.mode = OrientationMode::Anchors;
    (source ? p.sources : p.sinks) = {centre};
    auto f = texsynth::compute_orientation_field(m, p);
    expect_unit_tangent(m, f);
    for (int32_t v = 0; v < m.num_vertices; ++v) {
      double dx = g.positions[3 * v] - g.positions[3 * centre], dy = g.positions[3 * v + 1] - g.positions[3 * centre + 1];
      double r = std::hypot(dx, dy);
      if (r < 2.5) continue;
      const double radial[3] = {dx / r, dy / r, 0};
      double d = dot3(&f[3 * v], radial);
      EXPECT_GT(source ? d : -d, 0.9) << "vertex " << v << (source ? " source" : " sink");
    }
  }
}

TEST(FieldAnchors, SourceAndSinkAtPolesGiveMeridiansOnANoisySphere) {
  auto s = fixtures::uv_sphere(30, 40, 1.0, 0.03);
  auto m = texsynth::build_mesh(s.input());
  FieldParams p;
  p.mode = OrientationMode::Anchors;
  p.sources = {0};                    // south pole
  p.sinks = {m.num_vertices - 1};     // north pole
  auto f = texsynth::compute_orientation_field(m, p);
  expect_unit_tangent(m, f);
  int checked = 0;
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    double x = s.positions[3 * v], y = s.positions[3 * v + 1], z = s.positions[3 * v + 2];
    double r = std::sqrt(x * x + y * y + z * z), rxy = std::hypot(x, y);
    if (rxy < 0.3 * r) continue;
    const double north[3] = {-z * x / (rxy * r), -z * y / (rxy * r), rxy / r};  // unit meridian direction
    EXPECT_GT(dot3(&f[3 * v], north), 0.95) << "vertex " << v;
    ++checked;
  }
  EXPECT_GT(checked, 800);
}

TEST(FieldCaller, UnsetVectorsAreFilledFromSetOnes) {
  auto g = fixtures::grid(10, 10, 1.0, true);
  auto m = texsynth::build_mesh(g.input());
  std::vector<float> dir(size_t(m.num_vertices) * 3, 0.f);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    if (v % 3 == 0) dir[3 * v + 1] = 2.f;                 // set: +y
    else if (v % 3 == 1) dir[3 * v + 2] = 1.f;            // normal-parallel: unset
  }
  FieldParams p;
  p.mode = OrientationMode::Field;
  p.axis = {1.f, 0.f, 0.f};
  p.direction = dir.data();
  auto f = texsynth::compute_orientation_field(m, p);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    EXPECT_NEAR(f[3 * v], 0.0, 1e-6) << v;
    EXPECT_NEAR(f[3 * v + 1], 1.0, 1e-6) << v;
  }
}

TEST(FieldAnchors, IdenticalForOneAndTwoThreads) {
  auto s = fixtures::uv_sphere(40, 60, 1.0, 0.05);
  auto m = texsynth::build_mesh(s.input());
  FieldParams p;
  p.mode = OrientationMode::Anchors;
  p.anchor_vertices = {5, 900};
  p.anchor_directions = {{1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}};
  p.sources = {0};
  p.sinks = {m.num_vertices - 1};
  std::vector<float> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = texsynth::compute_orientation_field(m, p);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = texsynth::compute_orientation_field(m, p);
  }
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(0, std::memcmp(one.data(), two.data(), one.size() * sizeof(float)));
  expect_unit_tangent(m, one);
}

TEST(FieldErrors, BadParametersAreRejected) {
  auto g = fixtures::grid(3, 3, 1.0, true);
  auto m = texsynth::build_mesh(g.input());
  auto error = [&](FieldParams p) -> std::string {
    try {
      texsynth::compute_orientation_field(m, p);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  FieldParams p;
  p.mode = OrientationMode::Anchors;
  EXPECT_NE(error(p).find("needs"), std::string::npos);
  p.anchor_vertices = {100};
  p.anchor_directions = {{1.f, 0.f, 0.f}};
  EXPECT_NE(error(p).find("anchor_vertices[0] = 100"), std::string::npos) << error(p);
  p.anchor_vertices = {1};
  p.anchor_directions = {{0.f, 0.f, 1.f}};
  EXPECT_NE(error(p).find("parallel to the normal"), std::string::npos) << error(p);
  p.anchor_directions = {{NAN, 0.f, 1.f}};
  EXPECT_NE(error(p).find("NaN"), std::string::npos);
  FieldParams q;
  q.axis = {0.f, 0.f, 0.f};
  EXPECT_NE(error(q).find("axis"), std::string::npos);
  FieldParams r;
  r.mode = OrientationMode::Field;
  EXPECT_NE(error(r).find("direction"), std::string::npos);
  FieldParams s;
  s.mode = OrientationMode::Anchors;
  s.sinks = {-1};
  EXPECT_NE(error(s).find("sinks[0] = -1"), std::string::npos);
  EXPECT_THROW(texsynth::parse_orientation_mode("spiral"), std::invalid_argument);
}
