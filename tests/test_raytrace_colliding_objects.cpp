// SPDX-License-Identifier: MIT
// colliding_objects (hbp render --highlight-collisions) against brute force:
// the hybrid broad phase on the hierarchy's own cells must report every
// overlapping box pair exactly once (ownership de-duplication across the
// cells), and the narrow phase must then confirm the same pairs and flag the
// same objects as when it tests every overlapping pair of the frame.
#include <gtest/gtest.h>

#include <vector>

#include "hbp/brute_force.hpp"
#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/raytrace/colliding_objects.hpp"
#include "hbp/scenario.hpp"
#include "scenario_hierarchy.hpp"

namespace hbp {
namespace {

struct Case {
  ScenarioKind kind;
  std::uint32_t n, cell_limit, frames;
};

void expect_matches_brute_force(const Case& c) {
  test::ScenarioHierarchy w({.kind = c.kind, .n = c.n, .seed = 11}, {.cell_limit = c.cell_limit});
  for (std::uint32_t f = 0; f <= c.frames; ++f) {
    w.frame(f);
    const CollidingObjects got = colliding_objects(w.h, w.scenario.shapes());

    const std::vector<Pair> all = brute_force_pairs(w.boxes);
    std::vector<Contact> contacts;
    NarrowPhase({.contacts = false}).process(w.scenario.shapes(), all.data(), all.size(), contacts);
    std::vector<std::uint8_t> flags(w.scenario.size(), 0);
    for (const Contact& k : contacts) flags[k.a] = flags[k.b] = 1;

    SCOPED_TRACE("frame " + std::to_string(f));
    ASSERT_GT(w.h.cell_count(), 1u);  // pairs straddle cells: de-duplication has work
    EXPECT_EQ(got.candidate_pairs, all.size());
    EXPECT_EQ(got.colliding_pairs, contacts.size());
    EXPECT_EQ(got.flags, flags);
  }
}

TEST(CollidingObjects, PaperSceneManyCells) {
  expect_matches_brute_force({ScenarioKind::Paper, 2000, 64, 3});
}

TEST(CollidingObjects, HugeObjectsSpanningCells) {
  expect_matches_brute_force({ScenarioKind::Huge, 800, 40, 2});
}

TEST(CollidingObjects, DegenerateSceneTouchingFaces) {
  expect_matches_brute_force({ScenarioKind::Degenerate, 600, 16, 2});
}

}  // namespace
}  // namespace hbp
