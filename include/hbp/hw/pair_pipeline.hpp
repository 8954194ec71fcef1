// SPDX-License-Identifier: MIT
#pragma once
// The register stages between the buffer's address inputs and the pair output
// memory, as a delay line of `depth` cycles. A cycle's candidate pairs enter
// when its addresses are issued and their pair lines are written `depth`
// cycles later. The buffer is read-only during the sequence, so evaluating the
// comparators at issue and delaying the result is indistinguishable, at every
// observable point (addresses, write cycles, counters), from moving operands
// through each stage.
#include <cstdint>
#include <vector>

#include "hbp/pair.hpp"

namespace hbp::hw {

class PairPipeline {
 public:
  void configure(std::uint32_t depth);
  std::uint32_t depth() const { return depth_; }

  // Starts the bundle issued in `cycle`; the caller appends its pair lines to
  // the returned vector before the next call.
  std::vector<Pair>& issue(std::uint64_t cycle);
  // Writes the lines of the bundle issued `depth` cycles before `cycle` (if
  // any) to the pair memory. Returns the number of lines written.
  std::size_t retire(std::uint64_t cycle, std::vector<Pair>& pair_memory);
  // Bundles issued and not yet retired.
  std::uint32_t in_flight() const { return in_flight_; }

 private:
  struct Bundle {
    std::uint64_t retire_cycle = 0;
    bool occupied = false;
    std::vector<Pair> lines;
  };
  std::uint32_t depth_ = 0;
  std::uint32_t in_flight_ = 0;
  std::vector<Bundle> ring_;  // depth + 1 entries, indexed by issue cycle
};

}  // namespace hbp::hw
