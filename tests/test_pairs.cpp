// SPDX-License-Identifier: MIT
// Pair helpers: radix sort, canonicalisation, set differences and their
// summaries, and the oracle's closed-interval pairs on hand-made boxes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/pair.hpp"

namespace {

using hbp::Pair;

std::vector<Pair> random_pairs(std::size_t count, std::uint32_t max_id, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::uint32_t> id(0, max_id);
  std::vector<Pair> pairs;
  while (pairs.size() < count) {
    const std::uint32_t a = id(rng), b = id(rng);
    if (a != b) pairs.push_back(hbp::make_pair(a, b));
  }
  return pairs;
}

TEST(Pair, MakePairIsCanonicalAndOrderIsLexicographic) {
  EXPECT_EQ(hbp::make_pair(7, 3), (Pair{3, 7}));
  EXPECT_EQ(hbp::make_pair(3, 7), (Pair{3, 7}));
  EXPECT_LT((Pair{1, 9}), (Pair{2, 3}));
  EXPECT_LT((Pair{2, 3}), (Pair{2, 4}));
}

TEST(SortPairs, MatchesStdSortForSmallAndLargeIds) {
  // Below and above the radix threshold, small ids (upper passes skipped)
  // and ids using all 32 bits (every pass runs).
  for (std::uint32_t max_id : {1u, 100u, 2047u, 70000u, 1u << 20, 0xFFFFFFFFu}) {
    for (std::size_t count : {0u, 1u, 255u, 256u, 1023u, 1024u, 1025u, 100000u}) {
      auto pairs = random_pairs(count, max_id, static_cast<unsigned>(count + max_id));
      auto expected = pairs;
      std::sort(expected.begin(), expected.end());
      hbp::sort_pairs(pairs);
      EXPECT_EQ(pairs, expected) << "count " << count << " max id " << max_id;
    }
  }
}

TEST(SortPairs, ScratchOverloadReusesItsBufferAcrossSizes) {
  std::vector<Pair> scratch;
  for (std::size_t count : {50000u, 3000u, 200000u, 10u}) {
    auto pairs = random_pairs(count, 1u << 20, static_cast<unsigned>(count));
    auto expected = pairs;
    std::sort(expected.begin(), expected.end());
    hbp::sort_pairs(pairs, scratch);
    EXPECT_EQ(pairs, expected) << "count " << count;
  }
}

TEST(SortPairs, KeepsDuplicatesAndHandlesConstantDigits) {
  std::vector<Pair> pairs(1000, Pair{5, 0x10005});
  pairs[500] = {4, 0x10005};
  hbp::sort_pairs(pairs);
  EXPECT_EQ(pairs.front(), (Pair{4, 0x10005}));
  EXPECT_EQ(std::count(pairs.begin(), pairs.end(), Pair{5, 0x10005}), 999);
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));
}

TEST(Canonicalize, SwapsSortsAndCountsDuplicates) {
  std::vector<Pair> pairs = {{9, 2}, {2, 9}, {1, 3}, {3, 1}, {3, 1}, {0, 4}};
  EXPECT_EQ(hbp::canonicalize(pairs), 3u);
  EXPECT_EQ(pairs, (std::vector<Pair>{{0, 4}, {1, 3}, {2, 9}}));
  std::vector<Pair> clean = {{0, 1}, {0, 2}};
  EXPECT_EQ(hbp::canonicalize(clean), 0u);
  EXPECT_EQ(clean.size(), 2u);
}

TEST(Canonicalize, LargeSetEqualsSortedUniqueSet) {
  auto pairs = random_pairs(50000, 3000, 1);
  auto swapped = pairs;
  for (std::size_t i = 0; i < swapped.size(); i += 2) std::swap(swapped[i].a, swapped[i].b);
  swapped.insert(swapped.end(), pairs.begin(), pairs.begin() + 1000);  // 1000 more duplicates at least
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  const std::size_t before = swapped.size();
  const std::size_t removed = hbp::canonicalize(swapped);
  EXPECT_EQ(swapped, pairs);
  EXPECT_EQ(removed, before - pairs.size());
  EXPECT_GE(removed, 1000u);
}

TEST(Canonicalize, SelfPairIsAnError) {
  std::vector<Pair> pairs = {{1, 2}, {4, 4}};
  try {
    hbp::canonicalize(pairs);
    FAIL() << "self pair accepted";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("4-4"), std::string::npos) << e.what();
  }
}

TEST(DiffPairs, ReportsMissingAndExtra) {
  const std::vector<Pair> expected = {{0, 1}, {0, 2}, {1, 2}, {3, 4}};
  const std::vector<Pair> actual = {{0, 1}, {1, 2}, {2, 5}, {3, 4}, {6, 7}};
  const auto d = hbp::diff_pairs(expected, actual);
  EXPECT_FALSE(d.empty());
  EXPECT_EQ(d.missing, (std::vector<Pair>{{0, 2}}));
  EXPECT_EQ(d.extra, (std::vector<Pair>{{2, 5}, {6, 7}}));
  EXPECT_EQ(d.summary(), "1 missing (0-2), 2 extra (2-5, 6-7)");
  EXPECT_EQ(d.summary(1), "1 missing (0-2), 2 extra (2-5, ...)");
}

TEST(DiffPairs, IdenticalAndOneSided) {
  const std::vector<Pair> a = {{0, 1}, {2, 3}};
  EXPECT_TRUE(hbp::diff_pairs(a, a).empty());
  EXPECT_EQ(hbp::diff_pairs(a, a).summary(), "identical");
  EXPECT_EQ(hbp::diff_pairs(a, {}).summary(), "2 missing (0-1, 2-3)");
  EXPECT_EQ(hbp::diff_pairs({}, a).summary(), "2 extra (0-1, 2-3)");
}

TEST(BruteForce, ClosedIntervalsAndCanonicalOrder) {
  hbp::BoxArray b;
  b.push_back({{0, 0, 0}, {1, 1, 1}});
  b.push_back({{1, 0, 0}, {2, 1, 1}});        // shares a face with 0
  b.push_back({{2, 1, 1}, {3, 2, 2}});        // shares only a corner with 1
  b.push_back({{5, 5, 5}, {5, 5, 5}});        // a point, alone
  b.push_back({{0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}});  // a point inside 0
  b.push_back({{-0.0f, 0, 0}, {0, 0, 0}});    // a point on 0's corner (-0 == +0)
  b.push_back({{1.0f + 1e-7f, 2, 2}, {4, 3, 3}});  // touches 2 along an edge only
  const auto pairs = hbp::brute_force_pairs(b);
  EXPECT_EQ(pairs, (std::vector<Pair>{{0, 1}, {0, 4}, {0, 5}, {1, 2}, {2, 6}}));
}

}  // namespace
