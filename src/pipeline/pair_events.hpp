#pragma once
// Created and removed pairs between two frames: a linear merge of the sorted
// previous and current pair lists, split into independent ranges when large.
#include <vector>

#include "hbp/pair.hpp"

namespace hbp::detail {

// previous and current sorted by (a, b) (sort_pairs), no duplicates. created: in current
// only; removed: in previous only; both sorted.
void diff_sorted_pairs(const std::vector<Pair>& previous, const std::vector<Pair>& current,
                       std::vector<Pair>& created, std::vector<Pair>& removed);

}  // namespace hbp::detail
