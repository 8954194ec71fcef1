// SPDX-License-Identifier: MIT
#include "hbp/hw/analytic_cycles.hpp"

#include <algorithm>

namespace hbp::hw {

std::uint64_t area_efficient_sequence_cycles(std::uint64_t n, std::uint32_t m) {
  if (n < 2) return 0;
  // Anchor i needs ceil(k/q) cycles for its k = n-i-1 partners, q = 2m-1
  // partners per cycle; summing over k = 1..n-1 in whole blocks of q:
  // block b (k in ((b-1)q, bq]) contributes q*b, the partial block r*(a+1).
  const std::uint64_t q = 2ull * m - 1;
  const std::uint64_t partners = n - 1;
  const std::uint64_t a = partners / q;
  const std::uint64_t r = partners % q;
  return q * a * (a + 1) / 2 + r * (a + 1);
}

std::uint64_t many_object_sequence_cycles(std::uint64_t n, std::uint32_t m) {
  if (n == 0) return 0;
  const std::uint64_t rows = (n + m - 1) / m;
  // Arithmetic series: rows terms n-1, n-1-m, ..., n-1-(rows-1)m.
  return rows * (n - 1) - static_cast<std::uint64_t>(m) * rows * (rows - 1) / 2;
}

std::uint64_t many_object_rows(std::uint64_t n, std::uint32_t m) {
  if (n < 2) return 0;
  return (n - 1 + m - 1) / m;
}

std::uint32_t pipeline_depth(Design d, const ModelConfig& cfg) {
  const PipelineLatencies& l = cfg.latency;
  const std::uint32_t common = l.memory_read + l.compare + l.and_gate + l.pair_write;
  return d == Design::ManyObject ? common + l.reorder : common;
}

std::uint32_t comparisons_per_cycle(Design d, std::uint32_t m) {
  return d == Design::AreaEfficient ? 2 * m - 1 : m;
}

std::uint64_t buffer_capacity(Design d, const ModelConfig& cfg) {
  return d == Design::AreaEfficient ? cfg.depth
                                    : static_cast<std::uint64_t>(cfg.depth) * cfg.m;
}

std::uint32_t load_aabbs_per_cycle(Design d, const ModelConfig& cfg) {
  // Area-efficient: an AABB goes to the same address of all m groups, so each
  // memory's two ports take two AABBs per cycle at most. Many-object: AABB k
  // goes to group k mod m only, so 2m consecutive AABBs fit in one cycle.
  const std::uint32_t buffer_limit = d == Design::AreaEfficient ? 2 : 2 * cfg.m;
  return std::min(cfg.load_aabbs_per_cycle, buffer_limit);
}

CycleBreakdown analytic_cycles(Design d, std::uint64_t n, const ModelConfig& cfg) {
  CycleBreakdown c;
  if (cfg.count_load) {
    const std::uint64_t rate = load_aabbs_per_cycle(d, cfg);
    c.load = (n + rate - 1) / rate;
  }
  c.sequence = d == Design::AreaEfficient ? area_efficient_sequence_cycles(n, cfg.m)
                                          : many_object_sequence_cycles(n, cfg.m);
  if (c.sequence == 0) return c;
  const std::uint64_t depth = pipeline_depth(d, cfg);
  c.drain = depth;
  if (d == Design::ManyObject && cfg.row_change_drains_pipeline) {
    c.restart = depth * (many_object_rows(n, cfg.m) - 1);
  }
  return c;
}

Counters analytic_counters(Design d, std::uint64_t n, const ModelConfig& cfg) {
  Counters k;
  k.cycles = analytic_cycles(d, n, cfg);
  k.comparator_slots = k.cycles.sequence * comparisons_per_cycle(d, cfg.m);
  k.comparisons_performed = n < 2 ? 0 : n * (n - 1) / 2;
  k.comparisons_discarded = k.comparator_slots - k.comparisons_performed;
  return k;
}

}  // namespace hbp::hw
