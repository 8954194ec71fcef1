// SPDX-License-Identifier: MIT
#include "integrations/world/side_by_side.hpp"

#include <chrono>
#include <cstring>

#include "hbp/bullet/broadphase_adapter.hpp"
#include "support/clock.hpp"

namespace hbp::bullet::world {
namespace {

double timed_step(FallingShapesWorld& world) {
  const auto t = SteadyClock::now();
  world.step();
  return ms_since(t);
}

bool same_bits(const btVector3& a, const btVector3& b) {
  return std::memcmp(a.m_floats, b.m_floats, 3 * sizeof(btScalar)) == 0;
}

bool same_proxy_aabbs(FallingShapesWorld& a, FallingShapesWorld& b) {
  for (std::size_t i = 0; i < a.body_count(); ++i) {
    const btBroadphaseProxy* pa = a.body(i).getBroadphaseHandle();
    const btBroadphaseProxy* pb = b.body(i).getBroadphaseHandle();
    if (!same_bits(pa->m_aabbMin, pb->m_aabbMin) || !same_bits(pa->m_aabbMax, pb->m_aabbMax)) return false;
  }
  return true;
}

}  // namespace

ComparisonSummary run_side_by_side(const FallingShapesConfig& config, std::uint32_t steps,
                                   const BroadPhaseOptions& options,
                                   const std::function<void(const StepComparison&)>& on_step) {
  FallingShapesWorld hybrid(config, std::make_unique<BroadphaseAdapter>(options));
  FallingShapesWorld dbvt(config, std::make_unique<btDbvtBroadphase>());
  hybrid.dispatcher().set_recording(true);
  dbvt.dispatcher().set_recording(true);

  ComparisonSummary summary;
  for (std::uint32_t s = 1; s <= steps; ++s) {
    StepComparison c;
    c.step = s;
    c.hybrid_step_ms = timed_step(hybrid);
    c.dbvt_step_ms = timed_step(dbvt);
    const HandedPairs& h = hybrid.dispatcher().last();
    const HandedPairs& d = dbvt.dispatcher().last();
    c.hybrid_raw = h.raw;
    c.hybrid_exact = h.exact.size();
    c.dbvt_raw = d.raw;
    c.dbvt_exact = d.exact.size();
    c.same_aabbs = same_proxy_aabbs(hybrid, dbvt);
    const PairSetDiff diff = diff_pairs(d.exact, h.exact);
    c.same_pairs = diff.empty() && h.duplicates == 0 && d.duplicates == 0;
    if (!diff.empty()) c.difference = diff.summary();
    c.hybrid_contacts = hybrid.contacts();
    c.dbvt_contacts = dbvt.contacts();
    c.hybrid_timing = hybrid.timing();
    c.dbvt_timing = dbvt.timing();

    ++summary.steps;
    const bool identical = c.same_aabbs && c.same_pairs && c.hybrid_raw == c.hybrid_exact;
    if (identical) {
      ++summary.identical_steps;
    } else if (summary.first_mismatch == 0) {
      summary.first_mismatch = s;
    }
    summary.total_pairs += c.hybrid_exact;
    summary.max_pairs = std::max(summary.max_pairs, c.hybrid_exact);
    summary.hybrid_step_ms += c.hybrid_step_ms;
    summary.dbvt_step_ms += c.dbvt_step_ms;
    if (on_step) on_step(c);
    // The next step starts from the hybrid world's state in both worlds.
    dbvt.copy_state_from(hybrid);
  }
  return summary;
}

}  // namespace hbp::bullet::world
