// SPDX-License-Identifier: MIT
#pragma once
// Random boxes on a half-metre grid for the broad-phase tests: many overlaps,
// exactly touching faces, flat and point boxes, every coordinate exact in
// float.
#include <random>

#include "hbp/aabb.hpp"

namespace hbp::test {

// min on the grid in [0, world] per axis, each side 0 .. max_halves half-metres.
template <class World>
Aabb grid_box(std::mt19937& rng, World world, int max_halves) {
  std::uniform_int_distribution<int> pos(0, static_cast<int>(world * 2));
  std::uniform_int_distribution<int> size(0, max_halves);
  Aabb b;
  for (int k = 0; k < 3; ++k) {
    b.min[k] = 0.5f * static_cast<float>(pos(rng));
    b.max[k] = b.min[k] + 0.5f * static_cast<float>(size(rng));
  }
  return b;
}

// The broad-phase sessions' boxes: sides up to 3 m in a small world.
inline Aabb random_box(std::mt19937& rng, float world) { return grid_box(rng, world, 6); }

// b moved by -1 .. 1 m (half-metre steps) per axis: it stays on the grid.
inline Aabb nudged(std::mt19937& rng, Aabb b) {
  std::uniform_int_distribution<int> step(-2, 2);
  for (int k = 0; k < 3; ++k) {
    const float d = 0.5f * static_cast<float>(step(rng));
    b.min[k] += d;
    b.max[k] += d;
  }
  return b;
}

}  // namespace hbp::test
