// SPDX-License-Identifier: MIT
#pragma once
// Throughput counters of one run of a microarchitecture model. The analytic
// cycle functions produce the same CycleBreakdown without simulating.
#include <cstdint>

namespace hbp::hw {

struct CycleBreakdown {
  std::uint64_t load = 0;      // writing the n AABBs into the buffer
  std::uint64_t sequence = 0;  // cycles that issue buffer addresses
  std::uint64_t restart = 0;   // bubbles between rows (many-object)
  std::uint64_t drain = 0;     // after the last issue until the last pair line
  std::uint64_t total() const { return load + sequence + restart + drain; }
  friend bool operator==(const CycleBreakdown&, const CycleBreakdown&) = default;
};

struct Counters {
  CycleBreakdown cycles;
  std::uint64_t comparator_slots = 0;       // sequence cycles x pairs per cycle
  std::uint64_t comparisons_performed = 0;  // slots whose two objects are < n
  std::uint64_t comparisons_discarded = 0;  // slots touching an address >= n
  std::uint64_t pairs_written = 0;          // lines in the pair output memory

  // Useful comparisons per comparator slot during the sequence.
  double utilisation() const {
    return comparator_slots == 0 ? 0.0
                                 : static_cast<double>(comparisons_performed) /
                                       static_cast<double>(comparator_slots);
  }
};

}  // namespace hbp::hw
