// SPDX-License-Identifier: MIT
// detail::diff_sorted_pairs and map_and_diff_sorted_pairs (BroadPhase's
// created/removed events) against std::set_difference: random sorted lists
// sharing most pairs, from empty to several parallel ranges (16,384 pairs
// each), with and without an id map; same output for 1 and 2 threads.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <random>
#include <vector>

#include "hbp/pair.hpp"
#include "pair_sets.hpp"
#include "pipeline/pair_events.hpp"

namespace {

using hbp::Pair;
using hbp::test::minus;

// Sorted distinct pairs a < b with ids below `ids`.
std::vector<Pair> random_pairs(std::size_t n, std::uint32_t ids, std::mt19937& rng) {
  std::vector<Pair> v(n);
  for (Pair& p : v) {
    const auto a = static_cast<std::uint32_t>(rng() % ids), b = static_cast<std::uint32_t>(rng() % ids);
    p = hbp::make_pair(a, a == b ? (a + 1) % ids : b);
  }
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

// `previous` with a fraction of pairs dropped and some new ones inserted.
std::vector<Pair> evolve(const std::vector<Pair>& previous, double change, std::uint32_t ids, std::mt19937& rng) {
  std::vector<Pair> next;
  std::uniform_real_distribution<double> u(0, 1);
  for (const Pair p : previous)
    if (u(rng) >= change) next.push_back(p);
  const auto extra = random_pairs(static_cast<std::size_t>(change * static_cast<double>(previous.size())) + 3, ids, rng);
  next.insert(next.end(), extra.begin(), extra.end());
  std::sort(next.begin(), next.end());
  next.erase(std::unique(next.begin(), next.end()), next.end());
  return next;
}

TEST(PairEvents, DiffMatchesSetDifference) {
  std::mt19937 rng(11);
  hbp::detail::PairDiffScratch scratch;
  std::size_t changes = 0;
  for (const std::size_t n : {0, 1, 5, 100, 16383, 16384, 16385, 70000}) {
    for (const double change : {0.0, 0.02, 0.5, 1.0}) {
      const std::uint32_t ids = static_cast<std::uint32_t>(std::max<std::size_t>(8, n / 2));
      const auto previous = random_pairs(n, ids, rng);
      const auto current = evolve(previous, change, ids, rng);
      const auto want_created = minus(current, previous), want_removed = minus(previous, current);
      changes += want_created.size() + want_removed.size();
      for (const int threads : {1, 2}) {
        tbb::task_arena arena(threads);
        arena.execute([&] {
          std::vector<Pair> created{{1, 2}}, removed{{3, 4}};  // stale contents are replaced
          hbp::detail::diff_sorted_pairs(previous, current, created, removed, scratch);
          EXPECT_EQ(created, want_created) << n << " " << change;
          EXPECT_EQ(removed, want_removed) << n << " " << change;
          // Both directions, and against an empty list.
          hbp::detail::diff_sorted_pairs(current, previous, created, removed, scratch);
          EXPECT_EQ(created, want_removed);
          EXPECT_EQ(removed, want_created);
          hbp::detail::diff_sorted_pairs({}, current, created, removed, scratch);
          EXPECT_EQ(created, current);
          EXPECT_TRUE(removed.empty());
          // Mapped: ids through a strictly increasing map; previous in mapped ids.
          std::vector<std::uint32_t> to(ids + 1);
          for (std::uint32_t i = 0; i <= ids; ++i) to[i] = 5 * i + 2 + (i > ids / 3 ? 1000 : 0);
          auto mapped = [&](std::vector<Pair> v) {
            for (Pair& p : v) p = Pair{to[p.a], to[p.b]};
            return v;
          };
          std::vector<Pair> out{{7, 8}};
          hbp::detail::map_and_diff_sorted_pairs(mapped(previous), current, to.data(), out, created, removed,
                                                 scratch);
          EXPECT_EQ(out, mapped(current));
          EXPECT_EQ(created, mapped(want_created));
          EXPECT_EQ(removed, mapped(want_removed));
        });
        if (HasFailure()) return;
      }
    }
  }
  EXPECT_GT(changes, 100000u);
}

}  // namespace
