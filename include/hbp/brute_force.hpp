#pragma once
// The oracle: all-pairs over the closed-interval test, deliberately simple.
// Every engine, model and baseline is checked against it.
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp {

// Sorted, canonical pairs of all overlapping boxes.
std::vector<Pair> brute_force_pairs(const BoxArray& boxes);

}  // namespace hbp
