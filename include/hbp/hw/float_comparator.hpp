// SPDX-License-Identifier: MIT
#pragma once
// The compare stage's float32 comparators, built the way hardware builds
// them: on the raw IEEE-754 bit patterns, without a floating-point unit.
// Sign-magnitude patterns are mapped to unsigned keys whose integer order is
// the IEEE order, after folding -0 onto +0 so that -0 >= +0 and -0 <= +0 hold
// as IEEE-754 requires. NaN never reaches a comparator (the models reject it
// when the buffer is loaded).
#include <bit>
#include <cstdint>

namespace hbp::hw {

constexpr std::uint32_t ordered_key(std::uint32_t bits) {
  constexpr std::uint32_t kSign = 0x80000000u;
  if ((bits & ~kSign) == 0) bits = 0;  // -0 and +0 are one value
  // Negative numbers: larger magnitude is smaller, so invert every bit.
  return (bits & kSign) != 0 ? ~bits : (bits | kSign);
}

constexpr bool f32_greater_equal(std::uint32_t a, std::uint32_t b) {
  return ordered_key(a) >= ordered_key(b);
}

constexpr bool f32_less_equal(std::uint32_t a, std::uint32_t b) {
  return ordered_key(a) <= ordered_key(b);
}

inline std::uint32_t f32_bits(float f) { return std::bit_cast<std::uint32_t>(f); }

}  // namespace hbp::hw
