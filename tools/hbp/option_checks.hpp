// SPDX-License-Identifier: MIT
#pragma once
// Checks shared by the commands' numeric options, applied while parsing so a
// bad value stops the command before it does any work (CLI11 reports the
// option and the value; main() exits non-zero).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <string>

#include "hbp/limits.hpp"

namespace hbp::cli {

// --threads: 0 means every core; at most the library's limit.
inline CLI::Range threads_range() { return CLI::Range(0u, hbp::kMaxThreads); }

// Counts that must be at least 1 (frames, variants, ...).
inline CLI::Range at_least_one() { return CLI::Range(1u, 0xFFFFFFFFu); }

// A floating-point value that must be > 0 and finite: CLI11's own
// PositiveNumber lets NaN through (every comparison with NaN is false).
inline CLI::Validator positive_finite() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(text, v)) return "'" + text + "' is not a number";
        if (!std::isfinite(v) || !(v > 0)) return "must be a positive finite number (got " + text + ")";
        return {};
      },
      "POSITIVE", "positive finite");
}

}  // namespace hbp::cli
