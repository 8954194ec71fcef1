// SPDX-License-Identifier: MIT
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
// caller discards them on false). SSE2 four boxes at a time where available.
// `stream`: the caller's whole batch is far larger than the caches, so the
// lanes, when 16-byte aligned at begin (BoxArray's lanes, begin a multiple
// of 4), are written with non-temporal stores, fenced before returning (a
// plain store reads each line before writing it, and the lines would not
// stay in cache for the reader anyway).
// `previous` (six lanes, optional): the values the lanes held before; then
// *changed is the number of i in [begin, end) whose box differs from them
// (by value: -0 equals +0), counted in the same pass.
bool check_and_transpose(const Aabb* boxes, const std::uint32_t* ids, const std::uint32_t* expected,
                         std::size_t begin, std::size_t end, float* const lane[6], bool stream = false,
                         const float* const* previous = nullptr, std::uint32_t* changed = nullptr);

}  // namespace hbp::detail
