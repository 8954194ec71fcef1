// SPDX-License-Identifier: MIT
#pragma once
// Which objects collide, found on the two-level hierarchy's own k-d cells (the
// cells the collision engines read): HybridBroadPhase::update(KdPartition)
// finds the overlapping box pairs per cell, each kept in the one cell owning
// it (src/dedup/ownership.hpp), then the exact narrow phase. For
// `hbp render --highlight-collisions`.
#include <cstdint>
#include <vector>

#include "hbp/shape.hpp"
#include "hbp/two_level_hierarchy.hpp"

namespace hbp {

struct CollidingObjects {
  std::vector<std::uint8_t> flags;  // per object: 1 if it collides with another
  std::uint64_t candidate_pairs = 0;  // box pairs (after de-duplication)
  std::uint64_t colliding_pairs = 0;  // pairs the narrow phase confirms
};

CollidingObjects colliding_objects(const TwoLevelHierarchy& hierarchy, const std::vector<Shape>& shapes);

}  // namespace hbp
