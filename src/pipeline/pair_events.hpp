#pragma once
// Created and removed pairs between two frames: a linear merge of the sorted
// previous and current pair lists, split into independent ranges when large.
#include <vector>

#include "hbp/pair.hpp"

namespace hbp::detail {

// Sorts by (a, b): least-significant-digit radix sort on bytes, one counting
// pass for all digits, skipping digits every pair shares. `scratch` is the
// second buffer (kept by the caller between frames).
void sort_pair_list(std::vector<Pair>& pairs, std::vector<Pair>& scratch);

// previous and current sorted by (a, b), no duplicates. created: in current
// only; removed: in previous only; both sorted.
void diff_sorted_pairs(const std::vector<Pair>& previous, const std::vector<Pair>& current,
                       std::vector<Pair>& created, std::vector<Pair>& removed);

}  // namespace hbp::detail
