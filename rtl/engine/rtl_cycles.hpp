// SPDX-License-Identifier: MIT
#pragma once
// Cycle counts of the RTL (rtl/README.md, "Timing"), closed form: the
// paper's sequence formulas, the many-object row restarts and the pipeline
// drain. Equal to hbp::hw::analytic_cycles with the default ModelConfig
// (load not counted); the testbench checks RTL = model = this.
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

// Rows of the many-object sequence that issue at least one step.
inline std::uint64_t mo_rows(std::uint64_t n, std::uint64_t m) {
  return n < 2 ? 0 : (n - 1 + m - 1) / m;
}

// Register stages from a step's addresses to its pair lines being written:
// memory 2 + compare 2 + AND 1 + pair write 1 (+ reorder 1 for many-object),
// the C++ models' default PipelineLatencies.
inline std::uint64_t pipeline_latency(Design d) { return d == Design::kAreaEfficient ? 6 : 7; }

inline std::uint64_t sequence_cycles(Design d, std::uint64_t n, std::uint64_t m) {
  return d == Design::kAreaEfficient ? ae_sequence_cycles(n, m) : mo_sequence_cycles(n, m);
}

// Many-object: the sequencer holds one pipeline depth between rows.
inline std::uint64_t restart_cycles(Design d, std::uint64_t n, std::uint64_t m) {
  if (d == Design::kAreaEfficient || n < 2) return 0;
  return pipeline_latency(d) * (mo_rows(n, m) - 1);
}

// What the RTL's `cycles` counter reports (load excluded): sequence +
// restart + drain (one pipeline depth when there was a step).
inline std::uint64_t total_cycles(Design d, std::uint64_t n, std::uint64_t m) {
  const std::uint64_t s = sequence_cycles(d, n, m);
  return s + restart_cycles(d, n, m) + (s ? pipeline_latency(d) : 0);
}

}  // namespace hbp::rtl
