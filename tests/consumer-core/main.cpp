// SPDX-License-Identifier: MIT
// Links only the installed core library: the hybrid system on three boxes and
// a BroadPhase frame with a query. Exits 0 when both give the expected pairs.
#include <cstdio>
#include <vector>

#include "hbp/broad_phase.hpp"
#include "hbp/hybrid_broadphase.hpp"

int main() {
  hbp::BoxArray boxes;
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});
  boxes.push_back({{1, 0, 0}, {2, 1, 1}});  // touches box 0
  boxes.push_back({{5, 5, 5}, {6, 6, 6}});
  hbp::HybridBroadPhase core({.threads = 1});
  const auto& pairs = core.update(boxes);
  if (pairs.size() != 1 || pairs[0].a != 0 || pairs[0].b != 1) {
    std::fprintf(stderr, "HybridBroadPhase: expected pair 0-1, got %zu pairs\n", pairs.size());
    return 1;
  }

  hbp::BroadPhase bp({.threads = 1});
  const std::vector<hbp::Aabb> objects = {{{0, 0, 0}, {1, 1, 1}}, {{0.5f, 0.5f, 0.5f}, {2, 2, 2}}, {{9, 9, 9}, {10, 10, 10}}};
  const std::vector<hbp::Handle> h = bp.add(objects);
  const hbp::BroadPhaseUpdate& u = bp.update();
  const std::vector<hbp::Handle> hits = bp.query_box({{8, 8, 8}, {9.5f, 9.5f, 9.5f}});
  if (u.created.size() != 1 || u.created[0].a != h[0] || u.created[0].b != h[1] || hits.size() != 1 ||
      hits[0] != h[2]) {
    std::fprintf(stderr, "BroadPhase: %zu created pairs, %zu query hits (expected 1, 1)\n", u.created.size(),
                 hits.size());
    return 1;
  }
  std::printf("core consumer OK: pair 0-1, BroadPhase pair %u-%u, query hit %u\n", u.created[0].a, u.created[0].b,
              hits[0]);
  return 0;
}
