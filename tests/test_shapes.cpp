// SPDX-License-Identifier: MIT
// Tight AABBs of the four shapes under random rotations, checked against
// surface samples computed independently of the closed forms: parametric
// samples of each surface (refined around the extremes so the comparison is
// exact to ~1e-9) and support points in random directions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "hbp/shape.hpp"

namespace {

using hbp::Aabb;
using hbp::Quat;
using hbp::Shape;
using hbp::ShapeKind;
using hbp::Vec3;

constexpr double kPi = 3.14159265358979323846;

// A surface as a map from (s, t) in [0, 1]^2 to a local point; a shape is a
// union of such patches.
using Patch = std::function<Vec3(double, double)>;

std::vector<Patch> surface_patches(const Shape& shape) {
  const double ax = 0.5 * shape.size.x, ay = 0.5 * shape.size.y, az = 0.5 * shape.size.z;
  std::vector<Patch> patches;
  switch (shape.kind) {
    case ShapeKind::Sphere:
      patches.push_back([=](double s, double t) {
        const double theta = kPi * s, phi = 2 * kPi * t;
        return Vec3{ax * std::sin(theta) * std::cos(phi), ay * std::sin(theta) * std::sin(phi), az * std::cos(theta)};
      });
      break;
    case ShapeKind::Cuboid:
      for (int axis = 0; axis < 3; ++axis)
        for (double side : {-1.0, 1.0})
          patches.push_back([=](double s, double t) {
            const double u = 2 * s - 1, v = 2 * t - 1;
            if (axis == 0) return Vec3{side * ax, u * ay, v * az};
            if (axis == 1) return Vec3{u * ax, side * ay, v * az};
            return Vec3{u * ax, v * ay, side * az};
          });
      break;
    case ShapeKind::Cylinder:
      patches.push_back([=](double s, double t) {  // side wall
        const double phi = 2 * kPi * t;
        return Vec3{ax * std::cos(phi), ay * std::sin(phi), az * (2 * s - 1)};
      });
      for (double side : {-1.0, 1.0})
        patches.push_back([=](double s, double t) {  // caps
          const double phi = 2 * kPi * t;
          return Vec3{s * ax * std::cos(phi), s * ay * std::sin(phi), side * az};
        });
      break;
    case ShapeKind::Cone:
      patches.push_back([=](double s, double t) {  // lateral surface, apex at s = 0
        const double phi = 2 * kPi * t;
        return Vec3{s * ax * std::cos(phi), s * ay * std::sin(phi), az - 2 * az * s};
      });
      patches.push_back([=](double s, double t) {  // base
        const double phi = 2 * kPi * t;
        return Vec3{s * ax * std::cos(phi), s * ay * std::sin(phi), -az};
      });
      break;
  }
  return patches;
}

Vec3 to_world(const Shape& shape, const Vec3& p) {
  double r[3][3];
  hbp::rotation_matrix(shape.orientation, r);
  return {shape.position.x + r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z,
          shape.position.y + r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z,
          shape.position.z + r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z};
}

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Largest dot(world point, d) over a patch: a grid, then repeated finer grids
// around the best sample (the extremes of these smooth patches are isolated
// or lie on patch edges, where the clamped window still reaches them). The
// window in t starts as the whole circle: at a pole or apex every angle t
// samples the same point, so the best grid sample says nothing about t.
double patch_extreme(const Shape& shape, const Patch& patch, const Vec3& d) {
  constexpr int kGrid = 24;
  double best = -std::numeric_limits<double>::infinity(), bs = 0, bt = 0;
  auto probe = [&](double s, double t) {
    const double v = dot(to_world(shape, patch(s, t)), d);
    if (v > best) {
      best = v;
      bs = s;
      bt = t;
    }
  };
  for (int i = 0; i <= kGrid; ++i)
    for (int j = 0; j <= kGrid; ++j) probe(double(i) / kGrid, double(j) / kGrid);
  const bool periodic_t = shape.kind != ShapeKind::Cuboid;  // t is an angle
  double half_s = 1.0 / kGrid, half_t = periodic_t ? 0.5 : 1.0 / kGrid;
  for (int round = 0; round < 40; ++round) {
    const double cs = bs, ct = bt;
    for (int i = -4; i <= 4; ++i)
      for (int j = -4; j <= 4; ++j) {
        const double s = std::clamp(cs + half_s * i / 4, 0.0, 1.0);
        double t = ct + half_t * j / 4;
        t = periodic_t ? t - std::floor(t) : std::clamp(t, 0.0, 1.0);
        probe(s, t);
      }
    half_s *= 0.6;
    half_t *= 0.6;
  }
  return best;
}

// A reproducible spread of shapes: the paper's sizes, needles, pancakes,
// points, at positions near and far from the origin.
std::vector<Shape> test_shapes(ShapeKind kind, int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Shape> shapes;
  for (int i = 0; i < count; ++i) {
    Shape s;
    s.kind = kind;
    switch (i % 4) {
      case 0: s.size = {25 + 50 * unit(rng), 25 + 50 * unit(rng), 25 + 50 * unit(rng)}; break;
      case 1: s.size = {0.01 + unit(rng), 100 * unit(rng) + 50, 0.5 * unit(rng)}; break;  // extreme aspect
      case 2: s.size = {75, 25, 50}; break;
      default: s.size = {1e-3 * unit(rng), 40, 40}; break;
    }
    const double far = i % 3 == 0 ? 5000.0 : 50.0;
    s.position = {far * (2 * unit(rng) - 1), far * (2 * unit(rng) - 1), far * (2 * unit(rng) - 1)};
    // Uniform random rotation (Shoemake), plus exact axis-aligned ones.
    if (i % 10 == 9) {
      s.orientation = Quat{};
    } else if (i % 10 == 8) {
      s.orientation = hbp::normalized(Quat{1, 0, 0, 1});  // 90 degrees about z
    } else {
      const double u1 = unit(rng), u2 = unit(rng), u3 = unit(rng);
      s.orientation = hbp::normalized(Quat{std::sqrt(u1) * std::cos(2 * kPi * u3), std::sqrt(1 - u1) * std::sin(2 * kPi * u2),
                                           std::sqrt(1 - u1) * std::cos(2 * kPi * u2), std::sqrt(u1) * std::sin(2 * kPi * u3)});
    }
    shapes.push_back(s);
  }
  return shapes;
}

// Tolerance for "sample inside the box": the samples are computed in double
// with different rounding than the closed forms.
double slack(const Shape& s) { return 1e-9 * (std::fabs(s.position[0]) + std::fabs(s.position[1]) + std::fabs(s.position[2]) + 100); }

void check_tight_aabb(const Shape& shape, const std::string& what) {
  const Aabb box = hbp::tight_aabb(shape);
  const auto patches = surface_patches(shape);
  for (int axis = 0; axis < 3; ++axis) {
    ASSERT_LE(box.min[axis], box.max[axis]) << what;
    for (double sign : {1.0, -1.0}) {
      Vec3 d{axis == 0 ? sign : 0, axis == 1 ? sign : 0, axis == 2 ? sign : 0};
      double extreme = -std::numeric_limits<double>::infinity();
      for (const auto& patch : patches) extreme = std::max(extreme, patch_extreme(shape, patch, d));
      const double face = sign > 0 ? box.max[axis] : -static_cast<double>(box.min[axis]);
      const double extent = static_cast<double>(box.max[axis]) - box.min[axis];
      // Containment: the box face is outside every sample.
      EXPECT_GE(face, extreme - slack(shape)) << what << " axis " << axis << " sign " << sign;
      // Tightness: within 1e-4 of the box extent, plus the float rounding
      // of the face coordinate (one float ulp, the box is rounded outward).
      const float magnitude = static_cast<float>(std::fabs(face));
      const double ulp = static_cast<double>(std::nextafter(magnitude, std::numeric_limits<float>::infinity())) -
                         static_cast<double>(magnitude);
      EXPECT_LE(face - extreme, 1e-4 * extent + 2 * ulp + slack(shape))
          << what << " axis " << axis << " sign " << sign << " face " << face << " sampled " << extreme;
    }
  }
}

class TightAabb : public ::testing::TestWithParam<ShapeKind> {};

TEST_P(TightAabb, ContainsAndTouchesTheSurfaceUnderRandomRotations) {
  const ShapeKind kind = GetParam();
  int i = 0;
  for (const Shape& s : test_shapes(kind, 120, 1234 + static_cast<unsigned>(kind))) {
    check_tight_aabb(s, std::string(hbp::shape_kind_name(kind)) + " #" + std::to_string(i++));
  }
}

TEST_P(TightAabb, SupportPointsLieInTheBoxAndMaximiseTheirDirection) {
  const ShapeKind kind = GetParam();
  std::mt19937_64 rng(99);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (const Shape& s : test_shapes(kind, 40, 77 + static_cast<unsigned>(kind))) {
    const Aabb box = hbp::tight_aabb(s);
    const auto patches = surface_patches(s);
    for (int k = 0; k < 200; ++k) {
      const Vec3 d{normal(rng), normal(rng), normal(rng)};
      const Vec3 p = hbp::support_point(s, d);
      for (int a = 0; a < 3; ++a) {
        EXPECT_GE(p[a], box.min[a] - slack(s));
        EXPECT_LE(p[a], box.max[a] + slack(s));
      }
      if (k % 20 == 0) {
        // No surface point goes further in d, and the support point is
        // (within sampling accuracy) as far as the furthest one.
        double extreme = -std::numeric_limits<double>::infinity();
        for (const auto& patch : patches) extreme = std::max(extreme, patch_extreme(s, patch, d));
        const double scale = std::sqrt(dot(d, d)) * (s.size.x + s.size.y + s.size.z + 1);
        EXPECT_NEAR(dot(p, d), extreme, 1e-7 * scale + slack(s) * std::sqrt(dot(d, d)));
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllShapes, TightAabb,
                         ::testing::Values(ShapeKind::Sphere, ShapeKind::Cuboid, ShapeKind::Cylinder, ShapeKind::Cone),
                         [](const auto& info) { return std::string(hbp::shape_kind_name(info.param)); });

// Closed forms of simple cases, by hand.
TEST(TightAabbByHand, AxisAlignedShapes) {
  Shape s;
  s.size = {2, 4, 6};
  s.position = {10, 20, 30};
  for (auto kind : {ShapeKind::Sphere, ShapeKind::Cuboid, ShapeKind::Cylinder, ShapeKind::Cone}) {
    s.kind = kind;
    const Aabb b = hbp::tight_aabb(s);
    EXPECT_EQ(b.min[0], 9.0f) << hbp::shape_kind_name(kind);
    EXPECT_EQ(b.max[0], 11.0f) << hbp::shape_kind_name(kind);
    EXPECT_EQ(b.min[1], 18.0f) << hbp::shape_kind_name(kind);
    EXPECT_EQ(b.max[1], 22.0f) << hbp::shape_kind_name(kind);
    EXPECT_EQ(b.min[2], 27.0f) << hbp::shape_kind_name(kind);
    EXPECT_EQ(b.max[2], 33.0f) << hbp::shape_kind_name(kind);
  }
}

TEST(TightAabbByHand, RotatedCubeAndCone) {
  // A unit cube turned 45 degrees about z spans sqrt(2) in x and y.
  Shape cube;
  cube.kind = ShapeKind::Cuboid;
  cube.size = {1, 1, 1};
  const double h = std::sin(kPi / 8);
  cube.orientation = {std::cos(kPi / 8), 0, 0, h};
  Aabb b = hbp::tight_aabb(cube);
  EXPECT_NEAR(b.max[0], std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(b.min[1], -std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(b.max[2], 0.5, 1e-6);
  // A cone (apex +z) turned upside down about x: apex at -z, base at +z.
  Shape cone;
  cone.kind = ShapeKind::Cone;
  cone.size = {2, 2, 4};
  cone.orientation = {0, 1, 0, 0};
  b = hbp::tight_aabb(cone);
  EXPECT_FLOAT_EQ(b.min[2], -2.0f);
  EXPECT_FLOAT_EQ(b.max[2], 2.0f);
  // Tilted 90 degrees about y: axis along x, apex at +x... or -x; the base
  // disk (radius 1) spans y and z fully.
  cone.orientation = hbp::normalized({1, 0, 1, 0});
  b = hbp::tight_aabb(cone);
  EXPECT_NEAR(b.max[0] - b.min[0], 4.0, 1e-5);
  EXPECT_NEAR(b.max[1], 1.0, 1e-6);
  EXPECT_NEAR(b.min[2], -1.0, 1e-6);
}

TEST(TightAabbByHand, RoundsOutwardToFloat) {
  // 0.1 is not a float: the box must still contain the double-precision shape.
  Shape s;
  s.kind = ShapeKind::Cuboid;
  s.size = {0.2, 0.2, 0.2};
  s.position = {1000.0, -1000.0, 0.3};
  const Aabb b = hbp::tight_aabb(s);
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(static_cast<double>(b.min[a]), s.position[a] - 0.1);
    EXPECT_GE(static_cast<double>(b.max[a]), s.position[a] + 0.1);
    // ...and only by one float step.
    EXPECT_GT(static_cast<double>(std::nextafter(b.min[a], std::numeric_limits<float>::infinity())), s.position[a] - 0.1);
    EXPECT_LT(static_cast<double>(std::nextafter(b.max[a], -std::numeric_limits<float>::infinity())), s.position[a] + 0.1);
  }
}

TEST(TightAabbByHand, PointShapeIsAPointBox) {
  Shape s;
  s.kind = ShapeKind::Sphere;
  s.size = {0, 0, 0};
  s.position = {4, 5, 6};
  s.orientation = hbp::normalized({0.3, 0.1, -0.7, 0.2});
  const Aabb b = hbp::tight_aabb(s);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(b.min[a], static_cast<float>(s.position[a]));
    EXPECT_EQ(b.max[a], static_cast<float>(s.position[a]));
  }
}

TEST(Rotation, IntegrateRotationTurnsByTheAngularVelocity) {
  // 1 rad/s about z for pi/2 s: x goes to y.
  const Quat q = hbp::integrate_rotation(Quat{}, Vec3{0, 0, 1}, kPi / 2);
  double r[3][3];
  hbp::rotation_matrix(q, r);
  EXPECT_NEAR(r[0][0], 0.0, 1e-12);
  EXPECT_NEAR(r[1][0], 1.0, 1e-12);
  EXPECT_NEAR(r[2][2], 1.0, 1e-12);
  // Stays unit length over many steps.
  Quat p{};
  for (int i = 0; i < 10000; ++i) p = hbp::integrate_rotation(p, Vec3{2.5, -1.0, 0.7}, 1.0 / 60);
  EXPECT_NEAR(p.w * p.w + p.x * p.x + p.y * p.y + p.z * p.z, 1.0, 1e-12);
}

}  // namespace
