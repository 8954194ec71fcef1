// SPDX-License-Identifier: MIT
#pragma once
// De-duplication after the fact, for engines whose pair lists come out whole
// (brute force, the hardware models' simulation): the ownership rule
// (ownership.hpp) applied to a list of pairs.
#include <cstddef>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/pair.hpp"

namespace hbp::dedup {

// Keeps, in place and in order, the pairs out[from..) (local indices into
// `cell`) that region r owns, and drops the others.
void filter_owned(const BoxArray& cell, const CellRegion& r, std::vector<Pair>& out, std::size_t from);

}  // namespace hbp::dedup
