// SPDX-License-Identifier: MIT
#pragma once
// What the two buffer microarchitecture models share (paper section 3.1): a
// configuration, 6m buffer memories, the register pipeline to the pair output
// memory, a pair limit, and the cycle loop of a run. Load cycles, then
// one cycle per iteration: a sequence cycle issues addresses and its
// comparisons (or a restart bubble while a row change waits for the pipeline
// to empty), until the sequence ends; then drain cycles until the last pair
// line is written. What each design issues per cycle is its own sequencer
// (AreaEfficientModel, ManyObjectModel).
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/buffer_memories.hpp"
#include "hbp/hw/counters.hpp"
#include "hbp/hw/design.hpp"
#include "hbp/hw/model_config.hpp"
#include "hbp/hw/pair_limit_check.hpp"
#include "hbp/hw/pair_pipeline.hpp"
#include "hbp/hw/resources.hpp"
#include "hbp/pair.hpp"

namespace hbp::hw {

class BufferModel {
 public:
  const ModelConfig& config() const { return cfg_; }
  // Candidate pairs the compare stage evaluates per cycle: 2m-1 or m.
  std::uint32_t comparisons_per_cycle() const { return hw::comparisons_per_cycle(design_, cfg_.m); }
  std::uint32_t pipeline_depth() const;
  Resources resources() const;
  // Closed form of what run() counts for n objects (no capacity check).
  CycleBreakdown analytic_cycles(std::uint64_t n) const;

  // The buffer as the last run() left it (for inspecting the layout).
  const BufferMemories& buffer() const { return buffer_; }

  // Most pairs one run() may write (the cell engine passes max_pairs).
  void set_pair_limit(std::uint64_t limit) { pair_limit_ = limit; }
  std::uint64_t pair_limit() const { return pair_limit_; }

 protected:
  BufferModel(Design design, const ModelConfig& cfg);
  ~BufferModel() = default;

  // Throws CapacityExceeded / InvalidInput for boxes the buffer cannot hold.
  void check_input(const BoxArray& boxes) const;

  // Runs the cycles of one sequence over n loaded objects, appending pair
  // lines to pair_memory as the hardware writes them. Each sequence cycle
  // calls issue(cycle, lines, counters): it reads the buffer, appends the
  // cycle's hits to `lines`, counts its comparisons and returns whether the
  // sequence goes on. stalled() is true while the sequencer waits for the
  // pipeline to empty (a restart cycle, nothing issued).
  template <class Stalled, class Issue>
  Counters run_cycles(std::uint32_t n, std::vector<Pair>& pair_memory, Stalled&& stalled, Issue&& issue);

  Design design_;
  ModelConfig cfg_;
  BufferMemories buffer_;
  PairPipeline pipeline_;
  std::uint64_t pair_limit_ = ~std::uint64_t{0};
};

template <class Stalled, class Issue>
Counters BufferModel::run_cycles(std::uint32_t n, std::vector<Pair>& pair_memory, Stalled&& stalled,
                                 Issue&& issue) {
  pipeline_.configure(pipeline_depth());
  const std::size_t base = pair_memory.size();
  const std::uint32_t slots = comparisons_per_cycle();
  Counters k;
  std::uint64_t cycle = 0;
  if (cfg_.count_load) {
    const std::uint32_t rate = hw::load_aabbs_per_cycle(design_, cfg_);
    for (std::uint32_t written = 0; written < n; written += rate) ++cycle;
    k.cycles.load = cycle;
  }
  bool active = n >= 2;
  while (active || pipeline_.in_flight() > 0) {
    ++cycle;
    if (!active) {
      ++k.cycles.drain;
    } else if (stalled()) {
      ++k.cycles.restart;
    } else {
      ++k.cycles.sequence;
      active = issue(cycle, pipeline_.issue(cycle), k);
      k.comparator_slots += slots;
    }
    k.pairs_written += pipeline_.retire(cycle, pair_memory);
    check_pair_limit(pair_memory.size() - base, pair_limit_, n);
  }
  k.comparisons_discarded = k.comparator_slots - k.comparisons_performed;
  return k;
}

}  // namespace hbp::hw
