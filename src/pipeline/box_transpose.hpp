#pragma once
// One pass over a batch of boxes given as an array of Aabb: checks them and
// writes them into six SoA lanes (BoxArray's layout). BroadPhase::move() of
// every moving object runs through it, so the input is read once.
#include <cstddef>
#include <cstdint>

#include "hbp/aabb.hpp"

namespace hbp::detail {

// For i in [begin, end): lane[0..2][i] = boxes[i].min[0..2], lane[3..5][i] =
// boxes[i].max[0..2]. Returns true when every box is finite with min <= max
// (box_defect would find nothing) and every ids[i] equals expected[i], or i
// itself when expected is nullptr. The lanes are written either way (the
// caller discards them on false). SSE2 four boxes at a time where available;
// a range of at least 4,096 boxes whose lanes are 16-byte aligned at begin
// (BoxArray's lanes, begin a multiple of 4) is written with non-temporal
// stores, fenced before returning (a whole-world batch does not fit the
// caches, and a plain store reads each line before writing it).
bool check_and_transpose(const Aabb* boxes, const std::uint32_t* ids, const std::uint32_t* expected,
                         std::size_t begin, std::size_t end, float* const lane[6]);

}  // namespace hbp::detail
