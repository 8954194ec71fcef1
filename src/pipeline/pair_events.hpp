// SPDX-License-Identifier: MIT
#pragma once
// Created and removed pairs between two frames: a linear merge of the sorted
// previous and current pair lists, split into fixed ranges of the current
// list that run in parallel (the output is the same for any thread count).
#include <cstdint>
#include <span>
#include <vector>

#include "hbp/pair.hpp"

namespace hbp::detail {

// Per-range outputs kept between frames, so a frame does not allocate them
// (released when they hold far more than the last frame needed).
struct PairDiffScratch {
  std::vector<std::vector<Pair>> created, removed;
};

// previous and current sorted by (a, b) (sort_pairs), no duplicates. created: in current
// only; removed: in previous only; both sorted.
void diff_sorted_pairs(const std::vector<Pair>& previous, const std::vector<Pair>& current,
                       std::vector<Pair>& created, std::vector<Pair>& removed, PairDiffScratch& scratch);

// The same for current = raw with both ids mapped through `to` (current[i] =
// {to[raw[i].a], to[raw[i].b]}), written to `current` (resized to
// raw.size()) in the same pass as the merge. `to` must be strictly
// increasing, so the mapped list keeps raw's order and a < b.
void map_and_diff_sorted_pairs(const std::vector<Pair>& previous, std::span<const Pair> raw,
                               const std::uint32_t* to, std::vector<Pair>& current, std::vector<Pair>& created,
                               std::vector<Pair>& removed, PairDiffScratch& scratch);

}  // namespace hbp::detail
