// SPDX-License-Identifier: MIT
#pragma once
// The frame's pair list sorted by (a, b) on all threads of the broad phase
// (its arena or the engine's task system): what HybridBroadPhase's default sorted output and the
// engine API BroadPhase pay every frame.
//
// An MSD split, then independent buckets. One pass finds the range of the
// keys; the top bits of that range split the list into buckets (per-chunk
// histograms, then every chunk scatters its pairs into its own slots of each
// bucket: one pass over memory, stable); each bucket, a few thousand pairs
// that fit in L2, is then finished on its own by an LSD radix sort on the
// remaining low bits (three unrolled passes when they are at most 33, else
// support/radix_sort.hpp), writing the bucket's final place. The key is the serial
// sort's: (a << bits(b)) | b. A bucket too large to be finished by one
// thread (a skewed list: most pairs in a narrow range of a) is split again
// the same way on its own range, so no input degrades to one thread.
//
// Below kParallelPairSortFrom pairs, or on a one-thread arena, the serial
// sort_pairs runs: its result is the same (the order of distinct keys is
// unique, and equal keys are equal pairs), so the choice never shows.
//
// Memory: `scratch` (the caller's, kept between frames) holds the pairs while
// they are split, plus a tail for the per-chunk histograms (chunks x
// buckets 32-bit counts: 8 x 256 of them on 2 threads at a million pairs,
// at most 32 K, that is 16 K pairs of tail, inside the slack of the
// retained rule, support/retained.hpp); nothing else is allocated.
#include <tbb/task_arena.h>

#include <cstddef>
#include <vector>

#include "hbp/pair.hpp"
#include "pipeline/frame_threads.hpp"

namespace hbp {

// The serial sort is faster below about this many pairs (paper scene, 2
// threads: bench_pair_sort).
inline constexpr std::size_t kParallelPairSortFrom = 40000;

// Orders pairs by (a, b), exactly as sort_pairs, on the calling thread's
// threads (support/parallel_for.hpp: the engine's task system inside a
// broad phase's call, else oneTBB's current arena).
void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch);
// The same on the threads of `arena` (entered if the caller is not in it already).
void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, tbb::task_arena& arena);
// The same on a broad phase's threads.
inline void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, detail::FrameThreads& threads) {
  threads.execute([&] { parallel_sort_pairs(pairs, scratch); });
}

namespace detail {
// The sizes that choose a path, for tests that cross them on small lists and
// for the benchmark; parallel_sort_pairs uses the defaults.
struct PairSortLimits {
  std::size_t parallel_from = kParallelPairSortFrom;  // fewer pairs: serial sort_pairs
  std::size_t bucket_target = std::size_t{1} << 13;   // pairs a bucket of the split aims at
  std::size_t split_again_above = std::size_t{1} << 16;  // a larger bucket is split again, on all threads
  bool serial_on_one_thread = true;  // a one-thread arena runs the serial sort
};
void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, tbb::task_arena& arena,
                         const PairSortLimits& limits);
void parallel_sort_pairs(std::vector<Pair>& pairs, std::vector<Pair>& scratch, const PairSortLimits& limits);
}  // namespace detail

}  // namespace hbp
