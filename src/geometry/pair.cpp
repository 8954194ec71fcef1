// SPDX-License-Identifier: MIT
#include "hbp/pair.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <string>

#include "hbp/error.hpp"
#include "support/radix_sort.hpp"

namespace hbp {

namespace {

// Below this many pairs a comparison sort beats the radix sort's fixed costs.
constexpr std::size_t kComparisonSortBelow = 1024;

// Radix sort on the key (a << bits(b)) | b, which orders like (a, b) and
// holds only the bits the ids use (a million objects: 40 bits, 4 passes of
// 10 bits; 2048 buckets at most, so the histograms stay in L1).
void radix_sort(std::vector<Pair>& pairs, std::vector<Pair>& scratch) {
  const std::size_t n = pairs.size();
  if (n < kComparisonSortBelow) {
    std::sort(pairs.begin(), pairs.end());
    return;
  }
  std::uint32_t any_a = 0, any_b = 0;
  for (const Pair& p : pairs) {
    any_a |= p.a;
    any_b |= p.b;
  }
  const int bits_b = std::bit_width(any_b);
  const int bits = std::bit_width(any_a) + bits_b;
  scratch.resize(n);
  const Pair* sorted = hbp::radix_sort<11, 6>(pairs.data(), scratch.data(), n, bits, [bits_b](const Pair& p) {
    return (std::uint64_t{p.a} << bits_b) | p.b;
  });
  if (sorted != pairs.data()) std::copy(sorted, sorted + n, pairs.data());
}

std::string list(const std::vector<Pair>& v, std::size_t max_listed) {
  std::string s;
  for (std::size_t i = 0; i < v.size() && i < max_listed; ++i) {
    if (i) s += ", ";
    s += std::to_string(v[i].a) + "-" + std::to_string(v[i].b);
  }
  if (v.size() > max_listed) s += ", ...";
  return s;
}

}  // namespace

void sort_pairs(std::vector<Pair>& pairs) {
  std::vector<Pair> scratch;
  radix_sort(pairs, scratch);
}

void sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch) { radix_sort(pairs, scratch); }

std::size_t canonicalize(std::vector<Pair>& pairs) {
  for (auto& p : pairs) {
    if (p.a == p.b) throw InvalidInput("pair set contains self pair " + std::to_string(p.a) + "-" + std::to_string(p.b));
    if (p.a > p.b) std::swap(p.a, p.b);
  }
  sort_pairs(pairs);
  const auto end = std::unique(pairs.begin(), pairs.end());
  const std::size_t removed = static_cast<std::size_t>(pairs.end() - end);
  pairs.erase(end, pairs.end());
  return removed;
}

PairSetDiff diff_pairs(const std::vector<Pair>& expected, const std::vector<Pair>& actual) {
  PairSetDiff d;
  std::set_difference(expected.begin(), expected.end(), actual.begin(), actual.end(),
                      std::back_inserter(d.missing));
  std::set_difference(actual.begin(), actual.end(), expected.begin(), expected.end(),
                      std::back_inserter(d.extra));
  return d;
}

std::string PairSetDiff::summary(std::size_t max_listed) const {
  if (empty()) return "identical";
  std::string s;
  if (!missing.empty()) s += std::to_string(missing.size()) + " missing (" + list(missing, max_listed) + ")";
  if (!extra.empty()) {
    if (!s.empty()) s += ", ";
    s += std::to_string(extra.size()) + " extra (" + list(extra, max_listed) + ")";
  }
  return s;
}

}  // namespace hbp
