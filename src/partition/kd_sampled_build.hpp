#pragma once
// The from-scratch build of a large frame (the first frame and every
// rebuild), from a sample: the split planes are chosen on a sample of the
// objects (one in `rate`, a tree built with the cell limit divided by the
// rate), then every object is routed through the finished tree once, in id
// order, and written into every cell its box reaches (a count pass and a
// scatter pass over fixed chunks of ids), and each cell is put in min-x order
// in the cache. The exact build (kd_build.hpp) moves every entry through
// every level of the tree instead: 11 memory-bound passes over all entries
// at 1,024,000 objects.
//
// The cells are exact (the routing is the partition's own half-open rule);
// only the planes come from the sample. A cell the sample underestimated may
// come out over the limit: the caller splits it exactly, as it splits any
// leaf that grows over the limit between frames.
#include <tbb/enumerable_thread_specific.h>

#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/kd_partition.hpp"
#include "partition/kd_build.hpp"
#include "partition/raw_buffer.hpp"

namespace hbp::kd {

// The tree as the count pass walks it: 8 bytes a node (the whole tree of
// 2,048 cells in the L1 cache), a leaf a fixed point (split +inf: every box
// goes "left", to the leaf itself), so a group of objects steps down the
// tree together for as many levels as the deepest leaf, without a branch.
struct RouteNode {
  float split;
  std::uint32_t child_axis;  // child | axis << 30
};

// One object in `rate` goes into the sample (1: build exactly, with
// build_tree). Sampling needs frames large enough to be worth it and a cell
// limit that leaves enough samples per cell for its count to be estimated;
// the engine-cost rule needs exact counts under the limit, so it builds
// exactly.
std::uint32_t sample_rate(std::size_t n, const SplitRule& rule);

// Buffers kept from build to build (fresh pages cost more than the build).
struct SampledBuildBuffers {
  RawBuffer<CellEntry> sample;
  SubtreeBuilder sample_tree;
  BuildScratch sample_scratch;
  RawBuffer<std::uint32_t> counts;  // entries per (chunk of ids, cell), then each chunk's cursor per cell
  std::vector<RouteNode> route;  // the tree as the count pass walks it
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> forked;  // a chunk's objects in several cells
  std::vector<std::vector<std::uint32_t>> forked_cells;  // per chunk: their cells, object after object
  tbb::enumerable_thread_specific<std::vector<std::uint64_t>> sort_keys;
  tbb::enumerable_thread_specific<std::vector<CellEntry>> sort_entries;
};

// Builds the whole tree: nodes (node 0 the root), every leaf's entries in
// `entries` (min-x order, ties by id), for every object its home (the first
// node where its descent forked, else its leaf), and for objects homed at an
// inner node the box of this descent (prev) and its margin (the smallest
// distance from a face of the box to a plane it was tested against), so the
// next frame's maintenance need not descend them again. `scratch` is used
// for per-object words during the build (its contents are not kept).
// Deterministic for any thread count.
void build_tree_sampled(const BoxArray& boxes, const SplitRule& rule, std::uint32_t rate, SampledBuildBuffers& buffers,
                        RawBuffer<CellEntry>& scratch, std::vector<KdTreeNode>& nodes, RawBuffer<CellEntry>& entries,
                        std::uint32_t* home, StoredBox* prev, float* margin);

}  // namespace hbp::kd
