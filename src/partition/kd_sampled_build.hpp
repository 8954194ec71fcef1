// SPDX-License-Identifier: MIT
#pragma once
// The top levels of the from-scratch build of a large frame (the first frame
// and every rebuild), from a sample: the planes down to nodes of about a
// subtree task's size (kd_build.cpp: 2^15 entries) are chosen on one object
// in kTopSampleRate (each such node still decided on a thousand samples and
// more), then every object is routed through those levels once, in id order
// (a count pass and a scatter pass over fixed chunks of ids), into the tasks'
// buffers, and each task's entries are put in min-x order in the cache. The
// exact build moved every entry through every top level instead (six
// memory-bound passes over all entries at 1,024,000 objects, after a radix
// sort of all objects). The levels below, where the cells take their shape,
// are built exactly by the subtree tasks as before.
#include <tbb/enumerable_thread_specific.h>

#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/kd_partition.hpp"
#include "partition/raw_buffer.hpp"

namespace hbp::kd {

struct SplitRule;
class SubtreeBuilder;
struct BuildScratch;

// One node left for a serial subtree task: its entries are
// entries[begin, begin + n), sorted by min x, ties by id.
struct BuildTask {
  std::uint32_t node, depth;
  std::size_t begin;
  std::uint32_t n;
};

// The tree as the routing pass walks it: 8 bytes a node, a leaf a fixed
// point (split +inf: every box goes "left", to the leaf itself), so a group
// of objects steps down the tree together for as many levels as the deepest
// leaf, without a branch.
struct RouteNode {
  float split;
  std::uint32_t child_axis;  // child | axis << 30
};

// Buffers kept from build to build (fresh pages cost more than the build).
struct SampledTopBuffers {
  RawBuffer<CellEntry> sample;
  std::vector<RouteNode> route;
  RawBuffer<std::uint32_t> counts;  // entries per (chunk of ids, task), then each chunk's cursor per task
  std::vector<std::vector<std::uint32_t>> forked_tasks;  // per chunk: the tasks of its objects in several
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> forked;  // a chunk's objects in several tasks
};

// Whether a frame of n objects takes its top levels from a sample.
bool samples_top_levels(std::size_t n, std::uint32_t task_entries);

// Builds the top levels: nodes (node 0 the root; the tasks' nodes are leaves
// for now), the tasks in depth-first order, left before right, and their
// entries in `out` (build tags: kNoFork, or for an object the top levels
// route into several tasks the first fork, marked kNotOwner on all copies
// but the leftmost); `scratch` is overwritten. Nodes of at most task_entries entries (as the sample
// estimates them) are not split. Deterministic for any thread count.
void build_top_levels(const BoxArray& boxes, const SplitRule& rule, std::uint32_t task_entries,
                      SampledTopBuffers& buffers, SubtreeBuilder& sample_tree, BuildScratch& sample_scratch,
                      std::vector<KdTreeNode>& nodes, RawBuffer<CellEntry>& out, RawBuffer<CellEntry>& scratch,
                      std::vector<BuildTask>& tasks);

}  // namespace hbp::kd
