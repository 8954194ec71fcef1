// SPDX-License-Identifier: MIT
#pragma once
// Random shape pairs for the narrow phase's tests and benchmarks: the paper's
// size range, uniformly random orientations, and a share of near-touching
// placements found by bisection along a random direction.
#include <cstdint>

#include "hbp/shape.hpp"

namespace hbp {

struct ShapePairOptions {
  double size_min = 25.0, size_max = 75.0;  // per axis, as the paper's scene
  double circular_fraction = 0.25;  // true spheres / circular cylinders and cones
  double near_fraction = 0.5;       // near-touching placements
  double near_rel_min = 1e-7;       // near: offset moved by a relative amount
  double near_rel_max = 1e-2;       //   log-uniform in [min, max], either sign
  double world = 100.0;             // a centre uniform in [-world, world]^3
};

struct ShapePair {
  Shape a, b;
  bool near = false;      // placed near touching
  double near_rel = 0;    // signed relative offset from touching (near only)
};

class ShapePairGenerator {
 public:
  explicit ShapePairGenerator(std::uint64_t seed, const ShapePairOptions& options = {});
  ShapePair next(ShapeKind a, ShapeKind b);
  // Kinds chosen uniformly.
  ShapePair next();

 private:
  Shape random_shape(ShapeKind kind);
  std::uint64_t state_;
  ShapePairOptions options_;
  double uniform();
};

}  // namespace hbp
