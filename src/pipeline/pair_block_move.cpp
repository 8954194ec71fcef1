// SPDX-License-Identifier: MIT
#include "pipeline/pair_block_move.hpp"

#include <algorithm>
#include <cstring>

#include "support/parallel_for.hpp"

namespace hbp::detail {

namespace {

// Blocks under this many pairs (512 KiB) move with one memmove; a larger
// block overlapping by d is cut into chunks of at least this many times d
// (what a chunk sets aside: at most an eighth of the block).
constexpr std::size_t kMoveParallelPairs = std::size_t{1} << 16;
constexpr std::size_t kMoveChunksPerShift = 8;

}  // namespace

// Overlapping by a distance d, the block is cut into chunks of at least
// kMoveChunksPerShift d: each chunk first sets aside the d pairs that land in
// its neighbour's chunk (or the free gap) and moves the rest within itself;
// once all chunks have, the set-aside pairs go to their place. A large
// distance moves pieces of d one after another instead (each piece copied by
// all workers: it lands where the previous piece was).
void move_pair_block(Pair* base, std::size_t from, std::size_t to, std::size_t count, bool serial,
                     std::size_t chunks, RawBuffer<Pair>& scratch) {
  if (from == to || count == 0) return;
  const bool down = to < from;
  const std::size_t d = down ? from - to : to - from;
  if (count < kMoveParallelPairs || serial) {
    std::memmove(base + to, base + from, count * sizeof(Pair));
    return;
  }
  auto copy = [&](std::size_t src, std::size_t dst, std::size_t n) {  // no overlap: in parallel
    parallel_for_each(chunks, [&](std::size_t j) {
      const std::size_t lo = n * j / chunks, hi = n * (j + 1) / chunks;
      std::memcpy(base + dst + lo, base + src + lo, (hi - lo) * sizeof(Pair));
    });
  };
  if (d >= count) {
    copy(from, to, count);
    return;
  }
  if (d * kMoveChunksPerShift * chunks > count) {
    // Pieces of d, the one nearest the destination first.
    for (std::size_t done = 0; done < count; done += d) {
      const std::size_t n = std::min(d, count - done);
      const std::size_t src = down ? from + done : from + count - done - n;
      copy(src, down ? src - d : src + d, n);
    }
    return;
  }
  scratch.resize(chunks * d);
  parallel_for_each(chunks, [&](std::size_t j) {
    const std::size_t lo = from + count * j / chunks, hi = from + count * (j + 1) / chunks;
    Pair* aside = scratch.data() + j * d;
    if (down) {
      std::memcpy(aside, base + lo, d * sizeof(Pair));
      std::memmove(base + lo, base + lo + d, (hi - lo - d) * sizeof(Pair));
    } else {
      std::memcpy(aside, base + hi - d, d * sizeof(Pair));
      std::memmove(base + lo + d, base + lo, (hi - lo - d) * sizeof(Pair));
    }
  });
  parallel_for_each(chunks, [&](std::size_t j) {
    const std::size_t lo = from + count * j / chunks, hi = from + count * (j + 1) / chunks;
    std::memcpy(down ? base + lo - d : base + hi, scratch.data() + j * d, d * sizeof(Pair));
  });
}

}  // namespace hbp::detail
