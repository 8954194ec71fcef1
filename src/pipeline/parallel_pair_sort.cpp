// SPDX-License-Identifier: MIT
#include "pipeline/parallel_pair_sort.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <limits>

#include "support/parallel_for.hpp"
#include "support/radix_sort.hpp"

namespace hbp {

namespace {

// A split makes at most this many buckets (2,048: a chunk's histogram and
// its scatter targets stay in L1).
constexpr int kMaxSplitBits = 11;
constexpr std::size_t kMaxBuckets = std::size_t{1} << kMaxSplitBits;
// Chunks of a split per thread: a thread slowed by the machine's other work
// holds up one small chunk, not a quarter of the list.
constexpr std::size_t kChunksPerThread = 4;
constexpr std::size_t kMaxChunks = 64;
// At most this many histogram counts (chunks x buckets; 128 KiB, 16 K pairs
// of scratch's tail): within release_if_oversized's slack of 32 K pairs, so
// a list that grows a little does not make the caller drop and re-allocate
// its scratch. Many threads get fewer buckets (64 chunks: 512), not fewer
// chunks.
constexpr std::size_t kMaxCounts = std::size_t{1} << 15;
// A bucket this small is finished by a comparison sort (fewer instructions
// than a radix sort's histograms).
constexpr std::size_t kComparisonSortUpTo = 256;

// The serial sort's key: (a << bits(b)) | b orders like (a, b).
struct Key {
  int bits_b = 0;
  std::uint64_t operator()(const Pair& p) const { return (std::uint64_t{p.a} << bits_b) | p.b; }
};

// The bits that differ between the pairs of a block: AND and OR of every a
// and b (a vectorised pass; the keys agree above the highest bit where the
// two differ).
struct Bits {
  std::uint32_t and_a = ~0u, and_b = ~0u, or_a = 0, or_b = 0;
  Bits& operator+=(const Bits& o) {
    and_a &= o.and_a;
    and_b &= o.and_b;
    or_a |= o.or_a;
    or_b |= o.or_b;
    return *this;
  }
};

Bits bits_of(const Pair* p, std::size_t begin, std::size_t end) {
  Bits s;
  for (std::size_t i = begin; i != end; ++i) {
    s.and_a &= p[i].a;
    s.and_b &= p[i].b;
    s.or_a |= p[i].a;
    s.or_b |= p[i].b;
  }
  return s;
}

class Sorter {
 public:
  Sorter(const detail::PairSortLimits& limits, std::size_t chunks, int max_split_bits, std::uint32_t* counts)
      : limits_(limits), chunks_(chunks), max_split_bits_(max_split_bits), counts_(counts) {}

  // Sorts data[0, n) (spare[0, n) free); the result ends in data when
  // in_data, else in spare. The top call also fixes the key's b width.
  void sort_top(Pair* data, Pair* spare, std::size_t n, bool in_data) {
    const Bits b = bits(data, n);
    key_.bits_b = static_cast<int>(std::bit_width(b.or_b));
    split(data, spare, n, in_data, b);
  }

 private:
  Bits bits(const Pair* data, std::size_t n) const {
    const std::size_t grain = std::max<std::size_t>(4096, n / chunks_);
    return detail::parallel_reduce(
        n, grain, Bits{}, [data](std::size_t begin, std::size_t end, Bits s) { return s += bits_of(data, begin, end); },
        [](Bits x, const Bits& y) { return x += y; });
  }

  // Chunk c of a split of n items: [begin, end).
  std::size_t chunk_begin(std::size_t c, std::size_t n) const { return n * c / chunks_; }

  void split(Pair* data, Pair* spare, std::size_t n, bool in_data, const Bits& b) {
    const std::uint64_t all = key_(Pair{b.and_a, b.and_b});
    const std::uint64_t any = key_(Pair{b.or_a, b.or_b});
    const auto range_bits = static_cast<int>(std::bit_width(all ^ any));  // every key agrees above
    if (range_bits == 0) {  // one key (equal pairs): already in order
      if (!in_data) std::copy(data, data + n, spare);
      return;
    }
    const auto want = static_cast<int>(std::bit_width((n - 1) / limits_.bucket_target));
    const int d = std::clamp(want, 1, std::min(max_split_bits_, range_bits));
    const int shift = range_bits - d;
    const std::size_t buckets = std::size_t{1} << d;
    const std::uint64_t mask = buckets - 1;
    const Key key = key_;
    auto digit = [key, shift, mask](const Pair& p) { return static_cast<std::size_t>((key(p) >> shift) & mask); };

    // Per-chunk histograms, then each chunk's first slot in each bucket
    // (bucket-major: chunk 0's pairs of a bucket before chunk 1's, so the
    // split is stable).
    detail::parallel_for_each(chunks_, [&](std::size_t c) {
      std::uint32_t* row = counts_ + c * buckets;
      std::fill(row, row + buckets, 0u);
      for (std::size_t i = chunk_begin(c, n), e = chunk_begin(c + 1, n); i != e; ++i) ++row[digit(data[i])];
    });
    std::array<std::uint32_t, kMaxBuckets + 1> start;
    std::uint32_t sum = 0;
    for (std::size_t k = 0; k < buckets; ++k) {
      start[k] = sum;
      for (std::size_t c = 0; c < chunks_; ++c) {
        std::uint32_t& slot = counts_[c * buckets + k];
        const std::uint32_t t = slot;
        slot = sum;
        sum += t;
      }
    }
    start[buckets] = sum;
    detail::parallel_for_each(chunks_, [&](std::size_t c) {
      std::uint32_t* row = counts_ + c * buckets;
      for (std::size_t i = chunk_begin(c, n), e = chunk_begin(c + 1, n); i != e; ++i) spare[row[digit(data[i])]++] = data[i];
    });

    // The buckets are in spare; each ends where the block's result goes.
    const std::uint64_t low = (std::uint64_t{1} << shift) - 1;
    auto too_big = [&](std::size_t len) { return len > limits_.split_again_above && shift > 0; };
    detail::parallel_for_each(buckets, [&](std::size_t k) {
      const std::size_t s = start[k], len = start[k + 1] - s;
      if (!too_big(len)) finish(spare + s, data + s, len, !in_data, shift, low);
    });
    // A skewed list's big buckets: split again, one after another, each on
    // all threads (the histograms' storage is free again).
    for (std::size_t k = 0; k < buckets; ++k) {
      const std::size_t s = start[k], len = start[k + 1] - s;
      if (too_big(len)) split(spare + s, data + s, len, !in_data, bits(spare + s, len));
    }
  }

  // One bucket, in `first`, sorted by its low `bits` key bits on this
  // thread; the result ends in first when in_first, else in second.
  void finish(Pair* first, Pair* second, std::size_t len, bool in_first, int bits, std::uint64_t low) const {
    Pair* target = in_first ? first : second;
    const Pair* sorted = first;
    if (len <= kComparisonSortUpTo) {
      std::sort(first, first + len);
    } else if (bits <= 3 * kMaxSplitBits) {
      sorted = three_passes(first, second, len, bits, key_, low);
    } else {
      const Key key = key_;
      sorted = radix_sort<11, 6>(first, second, len, bits, [key, low](const Pair& p) { return key(p) & low; });
    }
    if (sorted != target) std::copy(sorted, sorted + len, target);
  }

  // The common bucket (the paper scene's: 32 key bits) by an LSD radix sort
  // of exactly three passes, digits fixed for the bucket, the three
  // histograms from one read with the loop unrolled (support's radix_sort,
  // which loops over a run-time pass count, took 14.1 against 11.7 ms for
  // the whole split on one thread at 1.54 M pairs, loaded machine). The
  // bucket's keys agree above `bits`, so a digit reaching past them orders
  // nothing wrongly. Returns the buffer holding the result (second: three
  // passes from first).
  static const Pair* three_passes(Pair* first, Pair* second, std::size_t len, int bits, Key key,
                                  std::uint64_t low) {
    const int digit = (bits + 2) / 3;
    const std::uint64_t mask = (std::uint64_t{1} << digit) - 1;
    const std::size_t size = std::size_t{1} << digit;
    std::array<std::uint32_t, 3 * kMaxBuckets> count;
    std::uint32_t* c0 = count.data();
    std::uint32_t* c1 = c0 + size;
    std::uint32_t* c2 = c1 + size;
    std::fill(c0, c0 + 3 * size, 0u);
    for (std::size_t i = 0; i < len; ++i) {
      const std::uint64_t k = key(first[i]) & low;
      ++c0[k & mask];
      ++c1[(k >> digit) & mask];
      ++c2[(k >> (2 * digit)) & mask];
    }
    std::uint32_t s0 = 0, s1 = 0, s2 = 0;
    for (std::size_t d = 0; d < size; ++d) {
      const std::uint32_t t0 = c0[d], t1 = c1[d], t2 = c2[d];
      c0[d] = s0;
      c1[d] = s1;
      c2[d] = s2;
      s0 += t0;
      s1 += t1;
      s2 += t2;
    }
    for (std::size_t i = 0; i < len; ++i) second[c0[key(first[i]) & mask]++] = first[i];
    for (std::size_t i = 0; i < len; ++i) first[c1[(key(second[i]) >> digit) & mask]++] = second[i];
    for (std::size_t i = 0; i < len; ++i) second[c2[((key(first[i]) & low) >> (2 * digit)) & mask]++] = first[i];
    return second;
  }

  const detail::PairSortLimits& limits_;
  std::size_t chunks_;
  int max_split_bits_;     // chunks_ << max_split_bits_ <= kMaxCounts
  std::uint32_t* counts_;  // chunks_ x buckets of the current split
  Key key_;
};

}  // namespace

void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch) {
  detail::parallel_sort_pairs(pairs, scratch, detail::PairSortLimits{});
}

void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, tbb::task_arena& arena) {
  detail::parallel_sort_pairs(pairs, scratch, arena, detail::PairSortLimits{});
}

namespace detail {

void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, tbb::task_arena& arena,
                         const PairSortLimits& limits) {
  arena.execute([&] {
    UseTaskSystem tbb_threads(nullptr);
    parallel_sort_pairs(pairs, scratch, limits);
  });
}

void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, const PairSortLimits& limits) {
  const std::size_t n = pairs.size();
  const auto threads = static_cast<std::size_t>(std::max(1, concurrency()));
  if (n < std::max<std::size_t>(limits.parallel_from, 2) || (threads == 1 && limits.serial_on_one_thread) ||
      n > std::numeric_limits<std::uint32_t>::max()) {
    sort_pairs(pairs, scratch);
    return;
  }
  const std::size_t chunks = std::min({kMaxChunks, kChunksPerThread * threads, n});
  // The first split has the most buckets (later ones split smaller blocks).
  static_assert(kMaxCounts / kMaxChunks >= 2);
  const int max_split_bits = std::min(kMaxSplitBits, static_cast<int>(std::bit_width(kMaxCounts / chunks)) - 1);
  const int top_bits = std::clamp(static_cast<int>(std::bit_width((n - 1) / std::max<std::size_t>(limits.bucket_target, 1))),
                                  1, max_split_bits);
  const std::size_t counts = chunks << top_bits;
  const std::size_t tail = (counts * sizeof(std::uint32_t) + sizeof(Pair) - 1) / sizeof(Pair);
  scratch.resize(n + tail);
  static_assert(sizeof(Pair) == 2 * sizeof(std::uint32_t) && alignof(Pair) >= alignof(std::uint32_t));
  auto* count_storage = reinterpret_cast<std::uint32_t*>(scratch.data() + n);
  PairSortLimits used = limits;
  used.bucket_target = std::max<std::size_t>(limits.bucket_target, 1);
  Sorter sorter(used, chunks, max_split_bits, count_storage);
  sorter.sort_top(pairs.data(), scratch.data(), n, true);
}

}  // namespace detail

}  // namespace hbp
