// SPDX-License-Identifier: MIT
#include "hbp/hw/model_config.hpp"

#include <cmath>
#include <string>

#include "hbp/error.hpp"

namespace hbp::hw {

void validate(const ModelConfig& cfg) {
  if (cfg.m < 1 || cfg.m > kMaxExtensibility) {
    throw InvalidInput("hardware model: extensibility factor m = " + std::to_string(cfg.m) +
                       " is outside 1.." + std::to_string(kMaxExtensibility));
  }
  if (cfg.depth == 0) throw InvalidInput("hardware model: memory depth must be at least 1 word");
  if (!(cfg.clock_hz > 0.0) || !std::isfinite(cfg.clock_hz)) {
    throw InvalidInput("hardware model: clock_hz = " + std::to_string(cfg.clock_hz) +
                       " must be positive and finite");
  }
  if (cfg.load_aabbs_per_cycle == 0) {
    throw InvalidInput("hardware model: load_aabbs_per_cycle must be at least 1");
  }
}

}  // namespace hbp::hw
