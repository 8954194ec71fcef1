// SPDX-License-Identifier: MIT
#pragma once
// What a run of frames reads and how it runs them, as `hbp run` parses it;
// `hbp run --distributed` takes the same request to its ranks.
#include <cstdint>
#include <string>

#include "hbp/scenario.hpp"

namespace hbp::cli {

struct RunRequest {
  std::string scene = "paper";
  std::string in;  // scene file instead of a scenario
  std::uint32_t n = 10000;
  std::uint32_t frames = 10;
  std::uint64_t seed = 0;
  std::string engine = "sw";
  std::uint32_t cell_limit = 0;
  unsigned threads = 0;
  bool json = false;
  bool quiet = false;
};

// The scenario a request without a scene file runs.
inline ScenarioParams scenario_params(const RunRequest& r) {
  ScenarioParams p;
  p.kind = parse_scenario_kind(r.scene);
  p.n = r.n;
  p.seed = r.seed;
  p.frames = r.frames;
  return p;
}

}  // namespace hbp::cli
