// SPDX-License-Identifier: MIT
#pragma once
// Per-object collision filtering as physics engines write it (Box2D's
// b2Filter): category and mask bits and a signed group, and the filter a
// query applies to the objects it reports. Used by hbp::BroadPhase.
#include <cstdint>

namespace hbp {

// An object's filter. Two objects collide (should_collide) when they share
// a nonzero group: always if it is positive, never if negative; otherwise
// when each one's category is in the other's mask. The defaults (category
// 1, every mask bit, group 0) collide with every default object.
struct Filter {
  std::uint64_t category = 1;
  std::uint64_t mask = ~std::uint64_t{0};
  std::int32_t group = 0;
  friend bool operator==(const Filter&, const Filter&) = default;
};

inline bool should_collide(const Filter& a, const Filter& b) {
  if (a.group == b.group && a.group != 0) return a.group > 0;
  return (a.category & b.mask) != 0 && (b.category & a.mask) != 0;
}

inline bool is_default(const Filter& f) { return f == Filter{}; }

// The objects a query reports: those whose layer bit is in layers_mask and
// whose category shares a bit with category_mask (the defaults pass all).
struct QueryFilter {
  std::uint32_t layers_mask = 0xFFFFFFFFu;
  std::uint64_t category_mask = ~std::uint64_t{0};
};

}  // namespace hbp
