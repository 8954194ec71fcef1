#include "pipeline/pair_events.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>

namespace hbp::detail {

namespace {

constexpr std::size_t kChunk = 1 << 16;  // current pairs per parallel range

void merge_range(const Pair* p, const Pair* p_end, const Pair* c, const Pair* c_end, std::vector<Pair>& created,
                 std::vector<Pair>& removed) {
  while (p != p_end && c != c_end) {
    if (*p < *c) {
      removed.push_back(*p++);
    } else if (*c < *p) {
      created.push_back(*c++);
    } else {
      ++p;
      ++c;
    }
  }
  removed.insert(removed.end(), p, p_end);
  created.insert(created.end(), c, c_end);
}

}  // namespace

void diff_sorted_pairs(const std::vector<Pair>& previous, const std::vector<Pair>& current,
                       std::vector<Pair>& created, std::vector<Pair>& removed) {
  created.clear();
  removed.clear();
  const std::size_t chunks = std::max<std::size_t>(1, (current.size() + kChunk - 1) / kChunk);
  if (chunks == 1 || previous.size() < kChunk) {
    merge_range(previous.data(), previous.data() + previous.size(), current.data(), current.data() + current.size(),
                created, removed);
    return;
  }
  // Range c covers current[c * kChunk, (c + 1) * kChunk) and the previous
  // pairs from the first >= its first pair to the first >= the next range's
  // first (the first range from the start, the last to the end): fixed
  // boundaries, so the output is the same for any thread count.
  std::vector<std::vector<Pair>> made(chunks), gone(chunks);
  const Pair* prev_begin = previous.data();
  const Pair* prev_end = previous.data() + previous.size();
  auto prev_bound = [&](std::size_t c) {
    if (c == 0) return prev_begin;
    if (c == chunks) return prev_end;
    return std::lower_bound(prev_begin, prev_end, current[c * kChunk]);
  };
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    const Pair* cur_begin = current.data() + c * kChunk;
    const Pair* cur_end = current.data() + std::min(current.size(), (c + 1) * kChunk);
    merge_range(prev_bound(c), prev_bound(c + 1), cur_begin, cur_end, made[c], gone[c]);
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    created.insert(created.end(), made[c].begin(), made[c].end());
    removed.insert(removed.end(), gone[c].begin(), gone[c].end());
  }
}

}  // namespace hbp::detail
