// SPDX-License-Identifier: GPL-3.0-or-later
// Principal curvature directions on surfaces with known (analytic) curvature.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

#include "mesh_fixtures.hpp"
#include "texsynth/field/curvature.hpp"
#include "texsynth/mesh/mesh.hpp"

namespace {

using fixtures::TestMesh;
const double kPi = 3.14159265358979323846;

// Open cylinder of radius r along z (quads, or triangles), outward-facing; sign flips the winding
// and so the normals (inward = concave).
TestMesh cylinder(int segments, int rows, double r, double height, bool inward) {
  TestMesh m;
  for (int i = 0; i <= rows; ++i)
    for (int j = 0; j < segments; ++j) {
      double a = 2 * kPi * j / segments;
      m.add_vertex(r * std::cos(a), r * std::sin(a), height * i / rows);
    }
  auto id = [&](int i, int j) { return int32_t(i * segments + (j % segments)); };
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < segments; ++j) {
      if (inward)
        m.add_poly({id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      else
        m.add_poly({id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j)});
    }
  return m;
}

void expect_axis_direction(const TestMesh& m, double r, double expected_steep) {
  texsynth::Mesh mesh = texsynth::build_mesh(m.input());
  texsynth::CurvatureResult c = texsynth::principal_curvature_directions(mesh);
  int checked = 0;
  float first_sign = 0;
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    const double z = m.positions[3 * size_t(v) + 2];
    if (z < 0.3 || z > 1.7) continue;  // away from the open rims
    const float* d = &c.min_direction[3 * size_t(v)];
    EXPECT_NEAR(std::fabs(d[2]), 1.0, 1e-3) << "vertex " << v;  // along the axis
    if (!first_sign) first_sign = d[2] > 0 ? 1.f : -1.f;
    EXPECT_GT(d[2] * first_sign, 0) << "signs must agree, vertex " << v;
    EXPECT_NEAR(c.curvatures[2 * size_t(v)], 0.0, 0.02) << "flat direction";
    EXPECT_NEAR(c.curvatures[2 * size_t(v) + 1], expected_steep, 0.05 * std::fabs(expected_steep));
    ++checked;
  }
  EXPECT_GT(checked, 100);
  (void)r;
}

TEST(FieldCurvature, CylinderFlatDirectionIsTheAxis) {
  // k = 1/r around, but a polygon of n segments has chord-based curvature 2 sin²(π/n)/(r (1-cos... ))
  // ≈ 1/r for fine tessellations.
  expect_axis_direction(cylinder(64, 20, 0.5, 2.0, false), 0.5, 2.0);
}

TEST(FieldCurvature, ConcaveCylinderStillFollowsTheAxis) {
  expect_axis_direction(cylinder(64, 20, 0.5, 2.0, true), 0.5, -2.0);
}

TEST(FieldCurvature, TiltedQuadCylinderFollowsItsAxis) {
  // Axis not aligned with any world axis, so tangent frames are rotated against the quad edges
  // (edges alone under-determine the fit there; polygon diagonals must be used).
  TestMesh m = cylinder(64, 20, 0.5, 2.0, false);
  const double c = std::cos(0.5), s = std::sin(0.5), c2 = std::cos(0.8), s2 = std::sin(0.8);
  std::vector<float> original = m.positions;
  for (size_t v = 0; v < m.positions.size() / 3; ++v) {
    double x = original[3 * v], y = original[3 * v + 1], z = original[3 * v + 2];
    double y1 = c * y - s * z, z1 = s * y + c * z;  // about X
    double x2 = c2 * x + s2 * z1, z2 = -s2 * x + c2 * z1;  // about Y
    m.positions[3 * v] = float(x2), m.positions[3 * v + 1] = float(y1), m.positions[3 * v + 2] = float(z2);
  }
  const double axis[3] = {s2 * c, -s, c2 * c};  // image of (0, 0, 1)
  texsynth::Mesh mesh = texsynth::build_mesh(m.input());
  texsynth::CurvatureResult r = texsynth::principal_curvature_directions(mesh);
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    const double z = original[3 * size_t(v) + 2];
    if (z < 0.3 || z > 1.7) continue;
    const float* d = &r.min_direction[3 * size_t(v)];
    EXPECT_GT(std::fabs(d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]), 0.999) << "vertex " << v;
  }
}

TEST(FieldCurvature, SphereAndPlaneHaveNoDirection) {
  TestMesh sphere = fixtures::uv_sphere(30, 40, 1.5);
  texsynth::Mesh mesh = texsynth::build_mesh(sphere.input());
  texsynth::CurvatureResult c = texsynth::principal_curvature_directions(mesh);
  int defined = 0, checked = 0;
  for (int32_t v = 0; v < sphere.num_vertices(); ++v) {
    const double z = sphere.positions[3 * size_t(v) + 2];
    if (std::fabs(z) > 1.0) continue;  // poles are fans: anisotropic sampling
    ++checked;
    const float* d = &c.min_direction[3 * size_t(v)];
    defined += d[0] != 0 || d[1] != 0 || d[2] != 0;
    EXPECT_NEAR(c.curvatures[2 * size_t(v)], 1 / 1.5, 0.08);
    EXPECT_NEAR(c.curvatures[2 * size_t(v) + 1], 1 / 1.5, 0.08);
  }
  EXPECT_LT(defined, checked / 20) << "umbilic points have no principal direction";

  TestMesh plane = fixtures::grid(10, 10, 0.1, true, 0.3);
  texsynth::Mesh pm = texsynth::build_mesh(plane.input());
  texsynth::CurvatureResult pc = texsynth::principal_curvature_directions(pm);
  for (float x : pc.min_direction) EXPECT_EQ(x, 0.f);
}

TEST(FieldCurvature, IdenticalForAnyThreadCount) {
  TestMesh sphere = fixtures::uv_sphere(60, 80, 1.0, 0.05);  // noisy: directions defined almost everywhere
  texsynth::Mesh mesh = texsynth::build_mesh(sphere.input());
  texsynth::CurvatureResult one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = texsynth::principal_curvature_directions(mesh);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = texsynth::principal_curvature_directions(mesh);
  }
  EXPECT_EQ(one.min_direction, two.min_direction);
  EXPECT_EQ(one.curvatures, two.curvatures);
}

TEST(FieldCurvature, RejectsBadParams) {
  TestMesh plane = fixtures::grid(2, 2, 1.0, true);
  texsynth::Mesh pm = texsynth::build_mesh(plane.input());
  texsynth::CurvatureParams p;
  p.smoothing_rings = -1;
  EXPECT_THROW(texsynth::principal_curvature_directions(pm, p), std::invalid_argument);
  p = {};
  p.anisotropy_threshold = std::nan("");
  EXPECT_THROW(texsynth::principal_curvature_directions(pm, p), std::invalid_argument);
}

}  // namespace
