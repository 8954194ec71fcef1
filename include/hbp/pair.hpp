// SPDX-License-Identifier: MIT
#pragma once
// A colliding pair, always canonical (a < b), and helpers to compare pair sets.
#include <compare>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace hbp {

// Default construction leaves a and b unset, as for a plain struct, but also
// for value-initialisation (Pair(), Pair{}, std::vector<Pair>::resize): a
// pair-dense first frame sizes a list of ~100 M pairs before the engine
// writes every one, and resize zero-filled it on one thread first (~45 ms
// per 100 M pairs; those first frames are 20-40 ms shorter without it).
// Give both ids (Pair{a, b}) to make a pair.
struct Pair {
  std::uint32_t a;
  std::uint32_t b;
  Pair() noexcept {}  // user-provided on purpose: no zero-fill (see above)
  constexpr Pair(std::uint32_t first, std::uint32_t second) noexcept : a(first), b(second) {}
  friend auto operator<=>(const Pair&, const Pair&) = default;
  friend bool operator==(const Pair&, const Pair&) = default;
};

static_assert(std::is_trivially_copyable_v<Pair> && std::is_standard_layout_v<Pair> && sizeof(Pair) == 8);
static_assert(!std::is_trivially_default_constructible_v<Pair>, "a trivial default would make resize zero-fill");

inline Pair make_pair(std::uint32_t i, std::uint32_t j) {
  return i < j ? Pair{i, j} : Pair{j, i};
}

// Orders pairs by (a, b) (radix sort: linear in the pair count).
void sort_pairs(std::vector<Pair>& pairs);
// The same with caller-kept scratch (resized to pairs.size()), so a frame
// loop does not allocate.
void sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch);

// Swaps each pair into a < b, sorts, and removes duplicates. Returns how many
// duplicates were removed (an engine that reports a pair twice is a bug the
// caller may want to see). Self pairs (a == b) throw InvalidInput.
std::size_t canonicalize(std::vector<Pair>& pairs);

// Difference between two sorted, canonical pair sets.
struct PairSetDiff {
  std::vector<Pair> missing;  // in expected, not in actual
  std::vector<Pair> extra;    // in actual, not in expected
  bool empty() const { return missing.empty() && extra.empty(); }
  // "3 missing (first: 4-17, ...), 1 extra (first: ...)" or "identical".
  std::string summary(std::size_t max_listed = 8) const;
};
PairSetDiff diff_pairs(const std::vector<Pair>& expected, const std::vector<Pair>& actual);

}  // namespace hbp
