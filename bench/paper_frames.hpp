// SPDX-License-Identifier: MIT
#pragma once
// Consecutive frames of the paper's scene for the benchmarks, generated once
// per object count and kept for the life of the benchmark binary.
#include <cstdint>
#include <map>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/scenario.hpp"

namespace hbp::bench {

// The first `count` frames of the paper's scene at n objects (the first call
// for an n fixes its count).
inline const std::vector<BoxArray>& paper_frames(std::uint32_t n, int count) {
  static std::map<std::uint32_t, std::vector<BoxArray>> cache;
  auto& frames = cache[n];
  if (frames.empty()) {
    ScenarioParams p;
    p.n = n;
    Scenario scene(p);
    for (int f = 0; f < count; ++f) {
      frames.emplace_back();
      scene.compute_boxes(frames.back());
      scene.step();
    }
  }
  return frames;
}

}  // namespace hbp::bench
