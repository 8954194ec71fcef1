// SPDX-License-Identifier: MIT
#pragma once
// Two runs of the example world from the same start, one with
// hbp::bullet::BroadphaseAdapter, one with btDbvtBroadphase, stepped side by
// side. After each step the Dbvt world takes the hybrid world's body states,
// so every step both broad phases see the same bodies (checked: every proxy's
// AABB must be bit-identical in both worlds). Each step compares the
// exact-filtered pairs handed to the narrow phase.
#include <cstdint>
#include <functional>
#include <string>

#include "hbp/hybrid_broadphase.hpp"
#include "integrations/world/falling_shapes_world.hpp"

namespace hbp::bullet::world {

struct StepComparison {
  std::uint32_t step = 0;       // 1-based
  std::size_t hybrid_raw = 0;   // pairs in the hybrid world's cache
  std::size_t hybrid_exact = 0;
  std::size_t dbvt_raw = 0;     // pairs in btDbvtBroadphase's cache
  std::size_t dbvt_exact = 0;
  bool same_aabbs = false;      // every proxy AABB bit-identical in both worlds
  bool same_pairs = false;      // exact-filtered pair sets identical
  std::string difference;       // hbp::PairSetDiff summary when not
  ContactCount hybrid_contacts, dbvt_contacts;
  BroadphaseTiming hybrid_timing, dbvt_timing;
  double hybrid_step_ms = 0, dbvt_step_ms = 0;
};

struct ComparisonSummary {
  std::uint32_t steps = 0;
  std::uint32_t identical_steps = 0;   // same AABBs, same pairs, hybrid raw == exact
  std::uint32_t first_mismatch = 0;    // 0: none
  std::uint64_t total_pairs = 0;       // sum of exact pairs over the steps
  std::size_t max_pairs = 0;
  double hybrid_step_ms = 0, dbvt_step_ms = 0;  // sums
};

ComparisonSummary run_side_by_side(const FallingShapesConfig& config, std::uint32_t steps,
                                   const BroadPhaseOptions& options,
                                   const std::function<void(const StepComparison&)>& on_step = {});

}  // namespace hbp::bullet::world
