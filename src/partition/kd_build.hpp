// SPDX-License-Identifier: MIT
#pragma once
// Building k-d (sub)trees over cell entries: the from-scratch build of the
// whole partition (parallel over subtrees) and the split of one over-full
// leaf (serial). Flat arrays only: entries are partitioned from one buffer
// into the next, never into per-node vectors.
//
// Entries arrive sorted by min x (ties by id) and every partition step is
// stable, so every leaf comes out sorted too: the cells' min-x order costs one
// radix sort per subtree task (of the objects, for a frame of one task), not
// one sort per cell. The levels above the tasks come from a sample
// (kd_sampled_build.hpp).
//
// While building, CellEntry::build_tag carries a tag per copy: the first node
// where the object forked into both children (its "home": the deepest node
// whose subtree holds all its cells) and whether this copy is the object's
// owner copy (the one that always went left at forks), so homes are assigned
// from exactly one copy without a second descent.
#include <tbb/enumerable_thread_specific.h>

#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/kd_partition.hpp"
#include "partition/kd_sampled_build.hpp"
#include "partition/raw_buffer.hpp"

namespace hbp::kd {

// A box as last seen (the maintenance compares the new box with it).
struct StoredBox {
  float min[3];
  float max[3];
};

inline constexpr std::uint32_t kNoHome = 0xFFFFFFFFu;
// Tag bits in CellEntry::build_tag while building.
inline constexpr std::uint32_t kNotOwner = 0x80000000u;
inline constexpr std::uint32_t kLocalNode = 0x40000000u;  // fork index is local to a SubtreeBuilder
inline constexpr std::uint32_t kForkMask = 0x3FFFFFFFu;
inline constexpr std::uint32_t kNoFork = kForkMask;
// Node indices must fit the tag's fork field.
inline constexpr std::uint32_t kMaxNodes = kForkMask;

struct SplitRule {
  std::uint32_t cell_limit;
  float x_split_weight;
  const KdPartition::CellCost* cell_cost;  // null or empty: split down to the limit only
};

struct Split {
  int axis = -1;
  float split = 0;
  std::uint32_t left = 0, right = 0;  // entries going to each child
};

// Where choose_split may put the chosen split's children: left[0..n] and
// right[0..n] (room for every entry and partition_entries' scratch slot).
struct PartitionTarget {
  std::uint32_t fork_tag;
  CellEntry* left;
  CellEntry* right;
};

// The split of a node holding e[0..n) at `depth`, or false when the node
// stays a leaf (at or under the limit, too deep, or no axis shrinks both
// children). With a target, a node over the limit counts its sides while
// partitioning into it (one read of every entry less than counting first),
// and on true the target holds partition_entries(e, n, out, fork_tag): the
// same split and children either way.
bool choose_split(const CellEntry* e, std::uint32_t n, std::uint32_t depth, const SplitRule& rule,
                  std::vector<std::uint32_t>& scratch, Split& out, const PartitionTarget* target = nullptr);

// Stable partition of e[0..n) into left (min < split) and right
// (max >= split); fork_tag is the node's tag for copies that go both ways.
// left[s.left] and right[s.right] must be writable scratch slots.
void partition_entries(const CellEntry* e, std::uint32_t n, const Split& s, std::uint32_t fork_tag, CellEntry* left,
                       CellEntry* right);

// The node a tag's fork field names: global as is; local ones belong to a
// subtree whose root is global node `root` and whose other local nodes k >= 1
// were appended at base + k - 1.
inline std::uint32_t fork_node(std::uint32_t tag, std::uint32_t root, std::uint32_t base) {
  const std::uint32_t f = tag & kForkMask;
  if (!(tag & kLocalNode)) return f;
  return f == 0 ? root : base + f - 1;
}

// Serial subtree build over a buffer that fits the cache (one leaf being
// split, or one task of the parallel build).
// Per-thread working memory of a subtree build, kept across frames (fresh
// pages cost more than the build itself on a virtual machine).
struct BuildScratch {
  RawBuffer<CellEntry> arena;  // a stack of node segments, parent before children
  std::vector<std::uint32_t> centres;  // choose_split's keys of the centres
};

class SubtreeBuilder {
 public:
  // A leaf's KdTreeNode::first with this bit set lies in `entries` (it did
  // not fit the caller's output); without it, in the caller's output.
  static constexpr std::uint32_t kSpilled = 0x80000000u;

  // items: sorted by min x, ties by id; tags as they come (reset_tags: start
  // fresh, for entries taken from a cell). Leaves go to `entries`.
  void build(const CellEntry* items, std::uint32_t n, std::uint32_t depth, const SplitRule& rule, bool reset_tags,
             BuildScratch& scratch);
  // The same, leaves written to out[0..out_capacity) while they fit (memory
  // the caller has touched already: fresh pages cost more than the build),
  // the rest to `entries` with kSpilled set in their leaf's first.
  void build_into(const CellEntry* items, std::uint32_t n, std::uint32_t depth, const SplitRule& rule,
                  BuildScratch& scratch, CellEntry* out, std::size_t out_capacity);
  // Entries in all leaves.
  std::size_t output_size() const { return out_size_ + entries.size(); }
  // Local nodes: 0 is the subtree's root, children indices local.
  std::vector<KdTreeNode> nodes;
  // Leaf after leaf (KdTreeNode::first relative to this buffer).
  RawBuffer<CellEntry> entries;

 private:
  void start(const CellEntry* items, std::uint32_t n, const SplitRule& rule, bool reset_tags, BuildScratch& scratch);
  void node(std::uint32_t at, std::size_t begin, std::uint32_t n, std::uint32_t depth);
  const SplitRule* rule_ = nullptr;
  BuildScratch* scratch_ = nullptr;
  CellEntry* out_ = nullptr;
  std::size_t out_capacity_ = 0;
  std::size_t out_size_ = 0;
  const CellEntry* root_items_ = nullptr;  // the root's entries when not copied into the arena
};

// Buffers of the from-scratch build. Only a and b outlive it (they are the
// caller's); the rest is freed when the tree is stitched (release_build_scratch).
struct BuildBuffers {
  // The top levels' ping-pong: two buffers the caller uses for other things
  // between builds (fresh pages are the build's largest cost).
  RawBuffer<CellEntry>* a = nullptr;
  RawBuffer<CellEntry>* b = nullptr;
  std::vector<SubtreeBuilder> tasks;   // one per subtree task: its output
  tbb::enumerable_thread_specific<BuildScratch> scratch;
  SampledTopBuffers top;               // the top levels from a sample
  SubtreeBuilder sample_tree;
};

// Entries the build's buffers (a, b and the output) reserve for `objects`
// objects: room for the top levels' duplicates and the tasks' slots.
std::size_t build_room(std::size_t objects);

// Builds the whole tree from scratch: nodes (node 0 the root), every leaf's
// entries in `entries`, home[i] (and for objects in several cells prev[i]
// and margin[i] = 0; an object in one cell has neither) for every object.
// Deterministic for any thread count.
void build_tree(const BoxArray& boxes, const SplitRule& rule, BuildBuffers& buffers, std::vector<KdTreeNode>& nodes,
                RawBuffer<CellEntry>& entries, std::uint32_t* home, StoredBox* prev, float* margin);
// Frees what build_tree used only while building (everything in buffers
// but the ping-pong buffers a and b); build_tree calls it when done.
void release_build_scratch(BuildBuffers& buffers);

// Entry order inside a cell: min x, then id.
inline bool entry_less(const CellEntry& a, const CellEntry& b) {
  return a.min[0] < b.min[0] || (a.min[0] == b.min[0] && a.id < b.id);
}

}  // namespace hbp::kd
