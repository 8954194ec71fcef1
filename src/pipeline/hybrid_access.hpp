// SPDX-License-Identifier: MIT
#pragma once
// BroadPhase's two private entries into HybridBroadPhase, for the frame in
// which every object moves:
// - update_checked: update() without re-validating the boxes. BroadPhase
//   validates every box when it is added or moved, so the frame's screen
//   over all boxes would be a second pass finding nothing.
// - swap_pairs: takes the frame's pair list without copying it; the hybrid
//   system writes its next frame into the storage it gets back.
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/pair.hpp"

namespace hbp::detail {

struct HybridAccess {
  // Every box in `boxes` must be finite with min <= max (unchecked).
  static const std::vector<Pair>& update_checked(HybridBroadPhase& hybrid, const BoxArray& boxes);
  // Exchanges the last frame's pairs with `other` (any contents).
  static void swap_pairs(HybridBroadPhase& hybrid, std::vector<Pair>& other);
};

}  // namespace hbp::detail
