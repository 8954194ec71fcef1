// SPDX-License-Identifier: MIT
// OrderedCell::load (a cell's entries to the engines' structure of arrays in
// min-x order): the lanes and ids against a plain stable sort of the
// entries, for every length up to a few vectors (the four-entry SSE2 body
// and the scalar tail), entries already in order (the direct copy) and out of
// order (the copy through the sort's permutation), with ties in min x.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "hbp/kd_partition.hpp"
#include "pipeline/ordered_cell.hpp"

namespace {

using hbp::CellEntry;

std::vector<CellEntry> random_entries(std::uint32_t n, std::mt19937& rng) {
  std::uniform_real_distribution<float> pos(-50, 50), side(0, 4);
  std::vector<CellEntry> entries(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    CellEntry& e = entries[i];
    for (int k = 0; k < 3; ++k) {
      // Min x from a few values only: ties, which keep their input order.
      e.min[k] = k == 0 ? static_cast<float>(rng() % 9) : pos(rng);
      e.max[k] = e.min[k] + side(rng);
    }
    e.id = 1000 + 7 * i;
    e.build_tag = 0;
  }
  return entries;
}

void expect_loaded(const hbp::OrderedCell& cell, std::span<const CellEntry> entries) {
  std::vector<CellEntry> expected(entries.begin(), entries.end());
  std::stable_sort(expected.begin(), expected.end(),
                   [](const CellEntry& a, const CellEntry& b) { return a.min[0] < b.min[0]; });
  ASSERT_EQ(cell.size(), expected.size());
  for (std::uint32_t i = 0; i < cell.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(cell.boxes().min(k)[i], expected[i].min[k]) << "box " << i << " min " << k;
      EXPECT_EQ(cell.boxes().max(k)[i], expected[i].max[k]) << "box " << i << " max " << k;
    }
    EXPECT_EQ(cell.ids()[i], expected[i].id) << "box " << i;
  }
}

TEST(OrderedCell, LoadsEntriesInOrderAndOutOfOrder) {
  std::mt19937 rng(7);
  hbp::OrderedCell cell;
  for (std::uint32_t n = 0; n <= 41; ++n) {
    std::vector<CellEntry> entries = random_entries(n, rng);
    cell.load(entries);
    expect_loaded(cell, entries);
    std::stable_sort(entries.begin(), entries.end(),
                     [](const CellEntry& a, const CellEntry& b) { return a.min[0] < b.min[0]; });
    cell.load(entries);
    EXPECT_TRUE(cell.was_sorted()) << n;
    expect_loaded(cell, entries);
  }
}

TEST(OrderedCell, ReversedCellIsReordered) {
  std::mt19937 rng(11);
  std::vector<CellEntry> entries = random_entries(1003, rng);
  std::sort(entries.begin(), entries.end(),
            [](const CellEntry& a, const CellEntry& b) { return a.min[0] > b.min[0]; });
  hbp::OrderedCell cell;
  cell.load(entries);
  EXPECT_FALSE(cell.was_sorted());
  expect_loaded(cell, entries);
}

}  // namespace
