#pragma once
// Cycle counts of the RTL (rtl/README.md, "Timing"): the paper's sequence
// formulas plus one load cycle per box and the pipeline drain.
#include <cstdint>

#include "rtl_driver.hpp"

namespace hbp::rtl {

// Paper 3.1.1: sum_{i=0}^{n-2} ceil((n-i-1)/(2m-1)).
inline std::uint64_t ae_sequence_cycles(std::uint64_t n, std::uint64_t m) {
  std::uint64_t s = 0;
  const std::uint64_t l = 2 * m - 1;
  for (std::uint64_t i = 0; i + 1 < n; ++i) s += (n - i - 1 + l - 1) / l;
  return s;
}

// Paper 3.1.2: sum_{i=0}^{ceil(n/m)-1} (n - i*m - 1).
inline std::uint64_t mo_sequence_cycles(std::uint64_t n, std::uint64_t m) {
  std::uint64_t s = 0;
  for (std::uint64_t i = 0; i * m < n; ++i) s += n - i * m - 1;
  return s;
}

// Cycles from a step to its pair lines on the compare-stage output port:
// area-efficient memory read + compare register; many-object adds the
// reorder register.
inline std::uint64_t pipeline_latency(Design d) { return d == Design::kAreaEfficient ? 2 : 3; }

inline std::uint64_t sequence_cycles(Design d, std::uint64_t n, std::uint64_t m) {
  return d == Design::kAreaEfficient ? ae_sequence_cycles(n, m) : mo_sequence_cycles(n, m);
}

// load (n) + sequence + drain (the latency, when there was a step).
inline std::uint64_t total_cycles(Design d, std::uint64_t n, std::uint64_t m) {
  const std::uint64_t s = sequence_cycles(d, n, m);
  return n + s + (s ? pipeline_latency(d) : 0);
}

}  // namespace hbp::rtl
