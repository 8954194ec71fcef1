// SPDX-License-Identifier: MIT
#include "pipeline/pair_events.hpp"

#include <algorithm>
#include <cstring>

#include "support/parallel_for.hpp"
#include "support/retained.hpp"

namespace hbp::detail {

namespace {

// Current pairs per parallel range: 128 KB of pairs, so a range's mapped
// pairs are still in cache when its merge reads them.
constexpr std::size_t kChunk = 1 << 14;

// (a, b) as one integer with the same order: one compare instead of two.
inline std::uint64_t key(Pair p) { return (static_cast<std::uint64_t>(p.a) << 32) | p.b; }

// Merges previous [p, p_end) with current [c, c_end). Most pairs are in both
// (frame coherence): runs of equal pairs are skipped four at a time (one
// 32-byte compare), and the equal case comes first and is well predicted.
void merge_range(const Pair* p, const Pair* p_end, const Pair* c, const Pair* c_end, std::vector<Pair>& created,
                 std::vector<Pair>& removed) {
  static_assert(sizeof(Pair) == 8, "four pairs are 32 bytes");
  auto step = [&] {  // one pair of the merge
    const std::uint64_t kp = key(*p), kc = key(*c);
    if (kp == kc) {
      ++p;
      ++c;
    } else if (kp < kc) {
      removed.push_back(*p++);
    } else {
      created.push_back(*c++);
    }
  };
  while (p_end - p >= 4 && c_end - c >= 4) {
    if (std::memcmp(p, c, 4 * sizeof(Pair)) == 0) {
      p += 4;
      c += 4;
    } else {
      step();
    }
  }
  while (p != p_end && c != c_end) step();
  removed.insert(removed.end(), p, p_end);
  created.insert(created.end(), c, c_end);
}

// Range c covers current[c * kChunk, (c + 1) * kChunk) and the previous
// pairs from the first >= its first pair to the first >= the next range's
// first (the first range from the start, the last to the end): fixed
// boundaries, so the output is the same for any thread count.
// `source(i)` is current[i] as it will be written; `fill(begin, end)` writes
// current[begin, end) before the range merges it (a range's boundaries are
// taken from `source`, since the next range may still be writing).
template <class Source, class Fill>
void diff_ranges(const std::vector<Pair>& previous, const Pair* current, std::size_t n, std::vector<Pair>& created,
                 std::vector<Pair>& removed, PairDiffScratch& scratch, Source&& source, Fill&& fill) {
  created.clear();
  removed.clear();
  const std::size_t chunks = std::max<std::size_t>(1, (n + kChunk - 1) / kChunk);
  if (chunks == 1) {
    fill(std::size_t(0), n);
    merge_range(previous.data(), previous.data() + previous.size(), current, current + n, created, removed);
    return;
  }
  scratch.created.resize(chunks);
  scratch.removed.resize(chunks);
  const Pair* prev_begin = previous.data();
  const Pair* prev_end = previous.data() + previous.size();
  auto bound = [&](std::size_t c) {
    if (c == 0) return prev_begin;
    if (c == chunks) return prev_end;
    const std::uint64_t k = key(source(c * kChunk));
    return std::partition_point(prev_begin, prev_end, [k](const Pair& q) { return key(q) < k; });
  };
  parallel_for_each(chunks, [&](std::size_t c) {
    const std::size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
    fill(begin, end);
    std::vector<Pair>& made = scratch.created[c];
    std::vector<Pair>& gone = scratch.removed[c];
    made.clear();
    gone.clear();
    merge_range(bound(c), bound(c + 1), current + begin, current + end, made, gone);
  });
  std::size_t made_total = 0, gone_total = 0;
  for (std::size_t c = 0; c < chunks; ++c) {
    made_total += scratch.created[c].size();
    gone_total += scratch.removed[c].size();
  }
  created.reserve(made_total);
  removed.reserve(gone_total);
  for (std::size_t c = 0; c < chunks; ++c) {
    created.insert(created.end(), scratch.created[c].begin(), scratch.created[c].end());
    removed.insert(removed.end(), scratch.removed[c].begin(), scratch.removed[c].end());
    retained::trim(scratch.created[c]);
    retained::trim(scratch.removed[c]);
  }
}

}  // namespace

void diff_sorted_pairs(const std::vector<Pair>& previous, const std::vector<Pair>& current,
                       std::vector<Pair>& created, std::vector<Pair>& removed, PairDiffScratch& scratch) {
  diff_ranges(
      previous, current.data(), current.size(), created, removed, scratch,
      [&](std::size_t i) { return current[i]; }, [](std::size_t, std::size_t) {});
}

void map_and_diff_sorted_pairs(const std::vector<Pair>& previous, std::span<const Pair> raw,
                               const std::uint32_t* to, std::vector<Pair>& current, std::vector<Pair>& created,
                               std::vector<Pair>& removed, PairDiffScratch& scratch) {
  current.resize(raw.size());
  Pair* out = current.data();
  const Pair* in = raw.data();
  diff_ranges(
      previous, out, raw.size(), created, removed, scratch,
      [&](std::size_t i) { return Pair{to[in[i].a], to[in[i].b]}; },
      [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) out[i] = Pair{to[in[i].a], to[in[i].b]};
      });
}

}  // namespace hbp::detail
