// SPDX-License-Identifier: MIT
#pragma once
// The one rule for buffers kept from frame to frame: a buffer's storage is
// given back when its capacity passes kFactor times what the current frame
// uses plus a slack. Memory then follows the current frame, not the peak of
// every frame before it, while a size that wobbles from frame to frame (or
// a small buffer) is not reallocated every frame.
//
//   retained::trim(v);               // keeps the contents, cuts the storage
//   retained::release(v, used);      // drops contents and storage if oversized
//
// The slack defaults to kSlackBytes worth of elements; a buffer kept once
// per cell (thousands of them) passes a smaller one.
#include <cstddef>

namespace hbp::retained {

inline constexpr std::size_t kFactor = 2;
inline constexpr std::size_t kSlackBytes = std::size_t{256} << 10;

template <class T>
inline constexpr std::size_t kSlack = kSlackBytes / sizeof(T) > 0 ? kSlackBytes / sizeof(T) : 1;

inline bool oversized(std::size_t capacity, std::size_t used, std::size_t slack) {
  return capacity > kFactor * used + slack;
}

// Cuts the storage of v (a std::vector or alike) to its size when oversized.
template <class V>
void trim(V& v, std::size_t slack = kSlack<typename V::value_type>) {
  if (oversized(v.capacity(), v.size(), slack)) v.shrink_to_fit();
}

// Drops v's contents and storage when its capacity is oversized for `used`
// elements (the next frame grows it again to what it needs).
template <class V>
void release(V& v, std::size_t used, std::size_t slack = kSlack<typename V::value_type>) {
  if (oversized(v.capacity(), used, slack)) V().swap(v);
}

}  // namespace hbp::retained
