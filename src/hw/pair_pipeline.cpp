// SPDX-License-Identifier: MIT
#include "hbp/hw/pair_pipeline.hpp"

namespace hbp::hw {

void PairPipeline::configure(std::uint32_t depth) {
  depth_ = depth;
  in_flight_ = 0;
  ring_.resize(static_cast<std::size_t>(depth) + 1);
  for (Bundle& b : ring_) {
    b.occupied = false;
    b.lines.clear();
  }
}

std::vector<Pair>& PairPipeline::issue(std::uint64_t cycle) {
  // The slot of the bundle issued depth+1 cycles ago, which retired at the
  // end of the previous cycle: a ring of depth+1 never overwrites a live one.
  Bundle& b = ring_[cycle % ring_.size()];
  b.occupied = true;
  b.retire_cycle = cycle + depth_;
  b.lines.clear();
  ++in_flight_;
  return b.lines;
}

std::size_t PairPipeline::retire(std::uint64_t cycle, std::vector<Pair>& pair_memory) {
  if (cycle < depth_) return 0;
  Bundle& b = ring_[(cycle - depth_) % ring_.size()];
  if (!b.occupied || b.retire_cycle != cycle) return 0;
  b.occupied = false;
  --in_flight_;
  pair_memory.insert(pair_memory.end(), b.lines.begin(), b.lines.end());
  return b.lines.size();
}

}  // namespace hbp::hw
