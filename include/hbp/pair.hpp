#pragma once
// A colliding pair, always canonical (a < b), and helpers to compare pair sets.
#include <compare>
#include <cstdint>
#include <string>
#include <vector>

namespace hbp {

struct Pair {
  std::uint32_t a;
  std::uint32_t b;
  friend auto operator<=>(const Pair&, const Pair&) = default;
  friend bool operator==(const Pair&, const Pair&) = default;
};

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
