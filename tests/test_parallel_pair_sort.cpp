// SPDX-License-Identifier: MIT
// The parallel sort of the frame's pair list (src/pipeline/parallel_pair_sort)
// against std::sort on 1 and 2 threads: random (20-bit, 16-bit and 32-bit
// ids), sorted, reversed,
// all-same-a, skewed (one bucket holding most pairs, split again), duplicate
// and full-width ids, empty and one-pair lists, at sizes crossing the serial
// threshold; small limits drive every path (deep re-splits, tiny buckets)
// on small lists. And the hybrid system's default sorted output against the
// oracle when the list is large enough to take the parallel path.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/pair.hpp"
#include "pipeline/parallel_pair_sort.hpp"

namespace {

using hbp::Pair;
using hbp::detail::PairSortLimits;

// Distinct canonical pairs (a < b) with ids in [0, max_id], in random order.
std::vector<Pair> random_pairs(std::size_t count, std::uint32_t max_id, std::mt19937& rng) {
  std::uniform_int_distribution<std::uint32_t> id(0, max_id);
  std::vector<Pair> pairs;
  pairs.reserve(count);
  while (pairs.size() < count) {
    const std::uint32_t a = id(rng), b = id(rng);
    if (a != b) pairs.push_back(hbp::make_pair(a, b));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::shuffle(pairs.begin(), pairs.end(), rng);
  return pairs;
}

// The kinds of list a frame can hand the sort.
std::vector<Pair> make_list(const std::string& kind, std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  if (kind == "random") return random_pairs(n, 1 << 20, rng);
  if (kind == "full-width") return random_pairs(n, 0xFFFFFFFFu, rng);  // 64-bit keys: every pass
  if (kind == "small-ids") return random_pairs(n, (1 << 16) - 1, rng);  // 32-bit keys: buckets in three passes
  if (kind == "sorted" || kind == "reversed") {
    auto v = random_pairs(n, 1 << 20, rng);
    std::sort(v.begin(), v.end());
    if (kind == "reversed") std::reverse(v.begin(), v.end());
    return v;
  }
  std::vector<Pair> v;
  if (kind == "same-a") {  // one object touching all others: the key's a part never differs
    for (std::uint32_t i = 0; i < n; ++i) v.push_back(Pair{3, 4 + i * 7});
    std::shuffle(v.begin(), v.end(), rng);
    return v;
  }
  if (kind == "skewed") {  // nine pairs in ten in a narrow a range, the rest spread
    std::uniform_int_distribution<std::uint32_t> hot(500000, 500003), any(0, 1 << 20);
    while (v.size() < n) {
      const std::uint32_t a = v.size() % 10 ? hot(rng) : any(rng), b = any(rng);
      if (a != b) v.push_back(hbp::make_pair(a, b));
    }
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    std::shuffle(v.begin(), v.end(), rng);
    return v;
  }
  if (kind == "duplicates") {  // not a frame's list (canonical pairs are unique), still sorted right
    std::uniform_int_distribution<std::uint32_t> id(0, 50);
    while (v.size() < n) {
      const std::uint32_t a = id(rng), b = id(rng);
      if (a != b) v.push_back(hbp::make_pair(a, b));
    }
    return v;
  }
  if (kind == "all-equal") return std::vector<Pair>(n, Pair{5, 9});
  ADD_FAILURE() << "unknown kind " << kind;
  return v;
}

const char* const kKinds[] = {"random", "full-width", "small-ids", "sorted", "reversed", "same-a", "skewed", "duplicates", "all-equal"};

void expect_sorted_like_std(std::vector<Pair> pairs, tbb::task_arena& arena, const PairSortLimits& limits,
                            const std::string& what) {
  std::vector<Pair> expected = pairs;
  std::sort(expected.begin(), expected.end());
  std::vector<Pair> scratch;
  hbp::detail::parallel_sort_pairs(pairs, scratch, arena, limits);
  ASSERT_EQ(pairs.size(), expected.size()) << what;
  const auto first_bad = std::mismatch(pairs.begin(), pairs.end(), expected.begin());
  ASSERT_TRUE(first_bad.first == pairs.end())
      << what << ": first difference at " << (first_bad.first - pairs.begin()) << " of " << pairs.size();
}

TEST(ParallelPairSort, MatchesStdSortAcrossTheSerialThreshold) {
  const std::size_t from = hbp::kParallelPairSortFrom;
  tbb::task_arena one(1), two(2);
  for (const char* kind : kKinds)
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, from - 1, from, from + 1, std::size_t{100000}}) {
      const std::vector<Pair> list = make_list(kind, n, static_cast<unsigned>(n) + 17);
      const std::string what = std::string(kind) + " n=" + std::to_string(n);
      expect_sorted_like_std(list, one, {}, what + " threads=1");
      expect_sorted_like_std(list, two, {}, what + " threads=2");
    }
}

// Small limits on small lists: several splits deep, buckets of every size
// (empty, one pair, comparison-sorted, radix-sorted), on one thread too.
TEST(ParallelPairSort, EveryPathWithSmallLimits) {
  PairSortLimits tiny;
  tiny.parallel_from = 2;
  tiny.bucket_target = 4;
  tiny.split_again_above = 300;
  tiny.serial_on_one_thread = false;
  for (int threads : {1, 2}) {
    tbb::task_arena arena(threads);
    for (const char* kind : kKinds)
      for (std::size_t n : {2, 3, 17, 255, 256, 257, 1000, 5000, 20000})
        expect_sorted_like_std(make_list(kind, n, static_cast<unsigned>(n) * 3 + 1), arena, tiny,
                               std::string(kind) + " n=" + std::to_string(n) + " threads=" + std::to_string(threads) +
                                   " (small limits)");
  }
}

// Two buckets a split, never split again: buckets on both sides of the
// comparison-sort limit (256 pairs), finished by std::sort, the three-pass
// radix sort (keys of at most 33 bits) or the general one (full-width ids).
TEST(ParallelPairSort, BucketsAcrossTheComparisonSortLimit) {
  PairSortLimits two;
  two.parallel_from = 2;
  two.bucket_target = std::size_t{1} << 30;
  two.split_again_above = std::size_t{1} << 30;
  two.serial_on_one_thread = false;
  tbb::task_arena arena(2);
  for (const char* kind : kKinds)
    for (std::size_t n : {200, 500, 512, 514, 600, 3000})
      expect_sorted_like_std(make_list(kind, n, static_cast<unsigned>(n) * 5 + 2), arena, two,
                             std::string(kind) + " n=" + std::to_string(n) + " (two buckets)");
}

// The parallel path keeps its histograms in scratch's tail: a few KiB, not a
// second list; below the threshold scratch is what the serial sort uses.
TEST(ParallelPairSort, ScratchHoldsTheListAndASmallTail) {
  tbb::task_arena arena(2);
  std::mt19937 rng(5);
  std::vector<Pair> pairs = random_pairs(200000, 1 << 20, rng), scratch;
  const std::size_t n = pairs.size();
  hbp::parallel_sort_pairs(pairs, scratch, arena);
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));
  EXPECT_GT(scratch.size(), n);  // the parallel path ran (its tail is there)
  EXPECT_LE(scratch.size(), n + 4096);

  // Many chunks (16 threads: 64) and small buckets: the split takes fewer
  // buckets so the tail stays within 16 K pairs (release_if_oversized's
  // slack), not 64 x 2,048 counts.
  tbb::task_arena many(16);
  PairSortLimits fine;
  fine.bucket_target = 16;
  std::vector<Pair> more = random_pairs(200000, 1 << 20, rng), more_scratch;
  expect_sorted_like_std(more, many, fine, "16 threads, buckets of 16");
  hbp::detail::parallel_sort_pairs(more, more_scratch, many, fine);
  EXPECT_GT(more_scratch.size(), more.size() + 8192);
  EXPECT_LE(more_scratch.size(), more.size() + 16384);

  std::vector<Pair> small = random_pairs(hbp::kParallelPairSortFrom / 2, 1 << 20, rng), small_scratch;
  hbp::parallel_sort_pairs(small, small_scratch, arena);
  EXPECT_TRUE(std::is_sorted(small.begin(), small.end()));
  EXPECT_EQ(small_scratch.size(), small.size());  // serial sort_pairs
}

// The hybrid system's default output (sorted) on a dense scene whose list
// takes the parallel path: the oracle's pairs in the oracle's order, on 1
// and 2 threads.
TEST(ParallelPairSort, HybridSortedOutputMatchesTheOracle) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> pos(0.0f, 100.0f), size(1.0f, 6.0f);
  hbp::BoxArray boxes;
  for (int i = 0; i < 6000; ++i) {
    const float x = pos(rng), y = pos(rng), z = pos(rng) * 0.05f, s = size(rng);
    boxes.push_back(hbp::Aabb{{x, y, z}, {x + s, y + s, z + s}});
  }
  const std::vector<Pair> expected = hbp::brute_force_pairs(boxes);
  ASSERT_GT(expected.size(), hbp::kParallelPairSortFrom);
  for (unsigned threads : {1u, 2u}) {
    hbp::HybridBroadPhase bp({.engine = "sw", .threads = threads});
    for (int frame = 0; frame < 2; ++frame) {
      const std::vector<Pair>& got = bp.update(boxes);
      ASSERT_EQ(got, expected) << "threads=" << threads << " frame " << frame;
    }
  }
}

}  // namespace
