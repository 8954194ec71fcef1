// SPDX-License-Identifier: MIT
#pragma once
// The centre of an interval [lo, hi], by halves: lo + hi overflows to
// infinity for finite boxes near the float limits, 0.5 lo + 0.5 hi does not.
// One expression for every box centre (the partition's split planes, the
// distributed ranks' domains).
namespace hbp::geometry {

inline float centre(float lo, float hi) { return 0.5f * lo + 0.5f * hi; }

}  // namespace hbp::geometry
