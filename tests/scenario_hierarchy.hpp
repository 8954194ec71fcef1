// SPDX-License-Identifier: MIT
#pragma once
// A scenario with a two-level hierarchy kept on its frames, for the tests
// that check the hierarchy (or what is built on it) frame after frame.
#include <cstdint>

#include "hbp/box_array.hpp"
#include "hbp/scenario.hpp"
#include "hbp/two_level_hierarchy.hpp"

namespace hbp::test {

struct ScenarioHierarchy {
  Scenario scenario;
  TwoLevelHierarchy h;
  BoxArray boxes;

  ScenarioHierarchy(const ScenarioParams& params, const HierarchyOptions& options) : scenario(params), h(options) {}

  // The hierarchy over frame f's boxes: frame 0 is the scenario's first
  // frame, every later call steps the scenario once first.
  void frame(std::uint32_t f) {
    if (f > 0) scenario.step();
    scenario.compute_boxes(boxes);
    h.update(boxes);
  }
};

}  // namespace hbp::test
