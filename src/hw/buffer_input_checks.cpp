// SPDX-License-Identifier: MIT
#include "hbp/hw/buffer_input_checks.hpp"

#include <cmath>
#include <string>

#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"

namespace hbp::hw {

void check_capacity(Design d, const ModelConfig& cfg, std::uint64_t n) {
  const std::uint64_t capacity = buffer_capacity(d, cfg);
  if (n <= capacity) return;
  const std::string why = d == Design::AreaEfficient
                              ? "every memory group holds a full copy, so capacity = depth"
                              : "capacity = depth x m";
  throw CapacityExceeded(std::string(design_name(d)) + " microarchitecture (m = " +
                         std::to_string(cfg.m) + ", depth = " + std::to_string(cfg.depth) +
                         ") holds at most " + std::to_string(capacity) + " objects (" + why +
                         "); asked to load " + std::to_string(n));
}

void check_buffer_input(Design d, const ModelConfig& cfg, const BoxArray& boxes) {
  check_capacity(d, cfg, boxes.size());
  static const char* const kLane[6] = {"min x", "min y", "min z", "max x", "max y", "max z"};
  for (int lane = 0; lane < 6; ++lane) {
    const float* v = lane < 3 ? boxes.min(lane) : boxes.max(lane - 3);
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      if (std::isnan(v[i])) {
        throw InvalidInput(std::string(design_name(d)) + " microarchitecture: object " +
                           std::to_string(i) + " has a NaN " + kLane[lane] +
                           " (float32 comparators do not order NaN)");
      }
    }
  }
}

}  // namespace hbp::hw
