// SPDX-License-Identifier: MIT
#pragma once
// LSD radix sort, written once: the k-d build's min-x order of all objects,
// a cell's min-x order (the sweep's input), the software engine's order of an
// unsorted cell, and the pair lists sorted by (a, b) all use radix_sort().
// Stable, linear in n, no comparisons and no allocation: the caller owns the
// scratch buffer (kept between frames).
#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace hbp {

// Order-preserving map from float to unsigned: key(x) < key(y) exactly when
// x < y (non-NaN). -0 is folded onto +0 first, so equal values get equal keys
// and fall back to whatever the caller packs below the key (an index), as a
// stable comparison sort would.
inline std::uint32_t float_order_key(float f) {
  const auto u = std::bit_cast<std::uint32_t>(f + 0.0f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

// Sorts items[0, n) by key(item), an unsigned integer of at most `key_bits`
// significant bits (key_bits <= kMaxDigitBits * kMaxPasses), stably. Digits of
// at most kMaxDigitBits bits, as few passes as that allows, all histograms
// from one read; a pass whose digit is the same for every item is skipped.
// `scratch` holds n items. Returns the buffer that holds the sorted items
// (items or scratch).
template <int kMaxDigitBits, int kMaxPasses, class T, class KeyFn>
T* radix_sort(T* items, T* scratch, std::size_t n, int key_bits, KeyFn key) {
  static_assert(kMaxDigitBits >= 1 && kMaxDigitBits <= 16 && kMaxPasses >= 1);
  if (n < 2 || key_bits <= 0) return items;
  const int passes = (key_bits + kMaxDigitBits - 1) / kMaxDigitBits;
  // More passes than the histograms have room for would write past them.
  if (passes > kMaxPasses) throw std::length_error("radix_sort: key wider than its digits x passes");
  const int digit = (key_bits + passes - 1) / passes;
  const std::uint64_t mask = (std::uint64_t{1} << digit) - 1;
  // Counts fit in 32 bits for up to 4 G items; the histograms stay in L1/L2.
  std::array<std::uint32_t, (std::size_t{kMaxPasses} << kMaxDigitBits)> count;
  std::memset(count.data(), 0, (static_cast<std::size_t>(passes) << digit) * sizeof(std::uint32_t));
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t k = key(items[i]);
    for (int q = 0; q < passes; ++q) ++count[(static_cast<std::size_t>(q) << digit) + ((k >> (q * digit)) & mask)];
  }
  T* src = items;
  T* dst = scratch;
  for (int q = 0; q < passes; ++q) {
    std::uint32_t* c = count.data() + (static_cast<std::size_t>(q) << digit);
    const int shift = q * digit;
    if (c[(key(src[0]) >> shift) & mask] == n) continue;  // every item has this digit
    std::uint32_t sum = 0;
    for (std::uint64_t d = 0; d <= mask; ++d) {
      const std::uint32_t t = c[d];
      c[d] = sum;
      sum += t;
    }
    for (std::size_t i = 0; i < n; ++i) dst[c[(key(src[i]) >> shift) & mask]++] = src[i];
    std::swap(src, dst);
  }
  return src;
}

// Sorts (key << 32 | index) words by their upper 32 bits (byte digits); the
// index makes every word unique, so the order is fully determined.
inline std::uint64_t* radix_sort_keyed_indices(std::uint64_t* words, std::uint64_t* scratch, std::size_t n) {
  return radix_sort<8, 4>(words, scratch, n, 32, [](std::uint64_t w) { return w >> 32; });
}

// order = the indices 0..n-1 by increasing values[i], ties by index (what
// std::stable_sort by value gives). scratch is grown to 2n words and kept.
inline void order_by_value(const float* values, std::uint32_t n, std::vector<std::uint32_t>& order,
                           std::vector<std::uint64_t>& scratch) {
  order.resize(n);
  if (scratch.size() < 2 * std::size_t{n}) scratch.resize(2 * std::size_t{n});
  std::uint64_t* a = scratch.data();
  for (std::uint32_t i = 0; i < n; ++i) a[i] = (std::uint64_t{float_order_key(values[i])} << 32) | i;
  constexpr std::uint32_t kComparisonSortUpTo = 48;  // below: fewer instructions than 4 histograms
  if (n <= kComparisonSortUpTo) {
    std::sort(a, a + n);
  } else {
    a = radix_sort_keyed_indices(a, scratch.data() + n, n);
  }
  for (std::uint32_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(a[i]);
}

}  // namespace hbp
