#include "hbp/pair.hpp"

#include <algorithm>
#include <cstdint>
#include <string>

#include "hbp/error.hpp"

namespace hbp {

namespace {

std::uint64_t key(const Pair& p) { return (std::uint64_t{p.a} << 32) | p.b; }

// LSD radix sort on the 64-bit (a, b) key, 16 bits per pass; skips passes whose
// digit is constant (small ids leave the top passes empty).
void radix_sort(std::vector<Pair>& pairs) {
  const std::size_t n = pairs.size();
  if (n < 256) {
    std::sort(pairs.begin(), pairs.end());
    return;
  }
  std::vector<Pair> tmp(n);
  Pair* src = pairs.data();
  Pair* dst = tmp.data();
  std::vector<std::size_t> count(1 << 16);
  for (int pass = 0; pass < 4; ++pass) {
    const int shift = pass * 16;
    std::fill(count.begin(), count.end(), 0);
    for (std::size_t i = 0; i < n; ++i) ++count[(key(src[i]) >> shift) & 0xffff];
    if (count[(key(src[0]) >> shift) & 0xffff] == n) continue;
    std::size_t sum = 0;
    for (auto& c : count) {
      const std::size_t t = c;
      c = sum;
      sum += t;
    }
    for (std::size_t i = 0; i < n; ++i) dst[count[(key(src[i]) >> shift) & 0xffff]++] = src[i];
    std::swap(src, dst);
  }
  if (src != pairs.data()) std::copy(src, src + n, pairs.data());
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

void sort_pairs(std::vector<Pair>& pairs) { radix_sort(pairs); }

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
