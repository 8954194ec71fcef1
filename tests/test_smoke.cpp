#include <gtest/gtest.h>
#include "hbp/scenario.hpp"
#include "hbp/brute_force.hpp"
TEST(Smoke, PaperScene) {
  hbp::ScenarioParams p; p.n = 1000;
  hbp::Scenario s(p);
  hbp::BoxArray b; s.compute_boxes(b);
  EXPECT_EQ(b.size(), 1000u);
  EXPECT_GT(hbp::brute_force_pairs(b).size(), 100u);
}
