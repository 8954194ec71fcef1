// SPDX-License-Identifier: MIT
#include "hbp/kd_partition.hpp"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <array>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "hbp/error.hpp"
#include "hbp/limits.hpp"
#include "partition/kd_build.hpp"
#include "partition/raw_buffer.hpp"
#include "support/parallel_for.hpp"
#include "support/prefault.hpp"
#include "support/retained.hpp"

namespace hbp {

namespace {

using kd::kNoHome;
using kd::StoredBox;

// The object pass works on fixed chunks of ids (a function of n only), so the
// cells' additions, concatenated chunk after chunk, come in increasing id
// order whatever the thread count. Small enough that 100,000 objects make
// a few dozen chunks (with a handful, one thread idles for most of a chunk
// at the end).
constexpr std::uint32_t kChunkObjects = 1u << 12;

// The rebuild rule: the tree is rebuilt (spread over the next frames, see
// rebuild_step) when the frame's
// duplication ratio exceeds kDuplicationGrowth times its value after the last
// rebuild plus kDuplicationSlack, when the cell count exceeds kCellGrowth
// times its value then plus kCellSlack, or when merged-away nodes make the
// node array more than kDeadNodeFactor times the live nodes plus
// kDeadNodeSlack.
constexpr double kDuplicationGrowth = 1.2;
constexpr double kDuplicationSlack = 0.01;
constexpr std::size_t kCellGrowth = 2;
constexpr std::size_t kCellSlack = 8;
constexpr std::size_t kDeadNodeFactor = 2;
constexpr std::size_t kDeadNodeSlack = 64;
// A spread rebuild is cut into about this many frames' shares: a frame
// rebuilds at most the entries / kRebuildFrames (at least two full cells,
// at most rebuild_budget()), so a small world's rebuild frame costs as
// little against its steady frame as a large world's.
constexpr std::uint64_t kRebuildFrames = 16;
// Sibling leaves merge (without a cell cost) when together they hold at most
// the cell limit divided by this.
constexpr std::uint32_t kMergeFraction = 4;

struct Box6 {
  float b[6];  // min x y z, max x y z
};

// The box reaches the half-open region (the routing rule: min < hi, max >= lo).
bool overlaps(const float* b, const CellRegion& r) {
  return (b[0] < r.hi[0]) & (b[3] >= r.lo[0]) & (b[1] < r.hi[1]) & (b[4] >= r.lo[1]) & (b[2] < r.hi[2]) &
         (b[5] >= r.lo[2]);
}
// The box reaches no region outside r (it cannot straddle any plane of r's
// boundary).
bool inside(const float* b, const CellRegion& r) {
  return (b[0] >= r.lo[0]) & (b[3] < r.hi[0]) & (b[1] >= r.lo[1]) & (b[4] < r.hi[1]) & (b[2] >= r.lo[2]) &
         (b[5] < r.hi[2]);
}

CellEntry make_entry(const Box6& x, std::uint32_t id) {
  return {{x.b[0], x.b[1], x.b[2]}, {x.b[3], x.b[4], x.b[5]}, id, 0};
}

// Nearly sorted (objects move a fraction of their size per frame): insertion
// sort is linear plus the few inversions.
void insertion_sort(CellEntry* e, std::uint32_t n) {
  if (n < 2) return;
  // The last key in order stays in a register: an entry past it costs a
  // load, a compare and a branch (half the instructions of entry_less on
  // two loaded entries).
  float last = e[0].min[0];
  for (std::uint32_t i = 1; i < n; ++i) {
    const float x = e[i].min[0];
    if (x > last) {
      last = x;
      continue;
    }
    if (!kd::entry_less(e[i], e[i - 1])) {  // equal min x, ids in order
      last = x;
      continue;
    }
    const CellEntry v = e[i];
    std::uint32_t j = i;
    do {
      e[j] = e[j - 1];
      --j;
    } while (j > 0 && kd::entry_less(v, e[j - 1]));
    e[j] = v;
  }
}

// e[0..k) and e[k..k+m) sorted: merges them in place, tail copied out first
// (the tail is the cell's few newcomers).
void merge_tail(CellEntry* e, std::uint32_t k, std::uint32_t m, std::vector<CellEntry>& tmp) {
  if (m == 0 || k == 0) return;
  tmp.assign(e + k, e + k + m);
  std::int64_t i = static_cast<std::int64_t>(k) - 1, j = static_cast<std::int64_t>(m) - 1;
  std::int64_t out = static_cast<std::int64_t>(k + m) - 1;
  while (j >= 0) {
    if (i >= 0 && kd::entry_less(tmp[static_cast<std::size_t>(j)], e[i])) e[out--] = e[i--];
    else e[out--] = tmp[static_cast<std::size_t>(j--)];
  }
}

// The members of one cell (src[0..size)) that still reach its region, with
// this frame's boxes from latest, copied to dst; returns how many. Everything
// it reads is a local (a parameter or a copy): the entry stores could alias
// anything reached through a pointer, which made the compiler reload the
// bases of every array once per entry.
std::uint32_t keep_members(const CellEntry* src, std::uint32_t size, const CellEntry* latest, std::uint32_t n,
                           const CellRegion& region, CellEntry* dst) {
  if (n == 0) return 0;  // every object removed
  // The routing rule (min < hi and max >= lo on every axis) as two 4-lane
  // compares on overlapping loads of the entry: {min x, min y, min z, max x}
  // < {hi x, hi y, hi z, +inf} and {min z, max x, max y, max z} >=
  // {-inf, lo x, lo y, lo z} (the padding lanes always pass: boxes are
  // finite). Portable vector extensions: SSE on x86-64, a third fewer
  // instructions per entry than six scalar compares.
  using V4 = float __attribute__((vector_size(16)));
  using I4 = std::int32_t __attribute__((vector_size(16)));
  static_assert(offsetof(CellEntry, min) == 0 && offsetof(CellEntry, max) == 12 && sizeof(CellEntry) == 32);
  const float inf = std::numeric_limits<float>::infinity();
  const V4 upper = {region.hi[0], region.hi[1], region.hi[2], inf};
  const V4 lower = {-inf, region.lo[0], region.lo[1], region.lo[2]};
  // Prefetch distance: the gather is random in id and a miss (~100 ns on the
  // measuring VM) outlasts eight entries' work (8: 30 % more refresh samples
  // than 24 or 48).
  constexpr std::uint32_t kAhead = 24;
  std::uint32_t k = 0;
  for (std::uint32_t e = 0; e < size; ++e) {
    if (e + kAhead < size) __builtin_prefetch(latest + std::min(src[e + kAhead].id, n - 1));
    const std::uint32_t id = src[e].id;
    if (id >= n) continue;  // object removed
    const CellEntry* x = latest + id;
    V4 a, b;
    std::memcpy(&a, &x->min[0], sizeof a);
    std::memcpy(&b, &x->min[2], sizeof b);
    const I4 in = (a < upper) & (b >= lower);
    std::uint64_t halves[2];
    std::memcpy(halves, &in, sizeof halves);
    dst[k] = *x;  // branch-free: kept when k advances (k <= e: inside the cell's room)
    k += (halves[0] & halves[1]) == ~std::uint64_t{0};
  }
  return k;
}

// Puts builder b's subtree in place of node `root`: inner nodes' children
// renumbered after the tree's current nodes, leaves' entries appended to
// `entries`. on_entry(entry, its leaf's node, base) sees each entry while
// its build tag (owner, fork) is still set; the tag is cleared after.
template <class Entries, class OnEntry>
void graft_subtree(std::vector<KdTreeNode>& nodes, Entries& entries, kd::SubtreeBuilder& b, std::uint32_t root,
                   OnEntry&& on_entry) {
  if (nodes.size() + b.nodes.size() > kd::kMaxNodes) throw CapacityExceeded("k-d partition: too many tree nodes");
  const auto base = static_cast<std::uint32_t>(nodes.size());
  const auto entry_base = static_cast<std::uint32_t>(entries.size());
  for (std::size_t j = 0; j < b.nodes.size(); ++j) {
    KdTreeNode nd = b.nodes[j];
    if (nd.axis >= 0) {
      nd.child = base + nd.child - 1;
    } else {
      const std::uint32_t global = j == 0 ? root : base + static_cast<std::uint32_t>(j) - 1;
      for (std::uint32_t i = nd.first; i < nd.first + nd.size; ++i) {
        CellEntry& e = b.entries[i];
        on_entry(e, global, base);
        e.build_tag = 0;
      }
      nd.first += entry_base;
    }
    if (j == 0) nodes[root] = nd;
    else nodes.push_back(nd);
  }
  entries.append(b.entries.data(), b.entries.size());
}

}  // namespace

struct KdPartition::State {
  RawBuffer<CellEntry> entries, next_entries;  // this frame's cells; the next frame's being written
  RawBuffer<std::uint32_t> home;               // object -> deepest node holding all its cells
  RawBuffer<StoredBox> prev;                   // object -> its box at its last descent (objects homed at an inner node)
  RawBuffer<float> margin;                     // object -> how far that box's faces were from every plane it was tested on
  std::size_t objects = 0;
  std::vector<CellRegion> node_regions;        // per live node
  std::vector<std::uint32_t> leaf_depth;       // cell -> depth of its leaf
  std::size_t live_nodes = 1;
  std::vector<std::vector<std::uint64_t>> chunk_adds;  // (cell << 32 | id) per chunk
  std::vector<std::uint32_t> add_offsets;              // cell -> first addition in add_ids
  std::vector<std::uint32_t> add_ids;
  std::vector<std::size_t> cell_offsets;       // cell -> its first entry in next_entries
  std::uint32_t frame_objects = 0;             // this frame's object count
  bool may_outgrow = false;                    // a cell may end this frame over the limit (and splittable)
  bool deferred = false;                       // begin_update left the cells' refresh to the caller
  bool split_pending = false;                  // a cell ended the last (deferred) frame over the limit
  tbb::enumerable_thread_specific<std::vector<CellEntry>> merge_scratch;
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> movers;  // find_crossings: objects to descend
  std::vector<CellEntry> merged;
  std::vector<std::uint32_t> sizes;
  RawBuffer<CellEntry> latest;                 // object -> this frame's box and id, as a cell entry
  kd::SubtreeBuilder splitter;
  kd::BuildScratch split_scratch;
  kd::BuildBuffers build;
  // The spread rebuild: subtree roots still to rebuild, in tree order.
  bool rebuilding = false;
  bool round_done = false;                     // the spread rebuild finished this frame
  std::vector<std::uint32_t> rebuild_queue;
  std::vector<std::uint64_t> rebuild_sizes;    // their entries when planned
  std::uint64_t rebuild_share = 0;             // entries a frame (and the largest subtree)
  std::size_t rebuild_cursor = 0;
  std::vector<std::uint32_t> node_seen;        // node -> number_leaves' stamp when it was last reachable
  std::vector<std::uint32_t> node_depth;       // node -> depth (reachable nodes)
  std::uint32_t seen_stamp = 0;
  std::vector<std::uint32_t> batch;            // this frame's subtree roots, in queue order
  std::vector<std::uint32_t> node_task;        // old node -> its batch index (kNoHome: none)
  struct SubtreeTask {
    std::vector<CellEntry> gathered;           // the subtree's objects, once each
    kd::SubtreeBuilder builder;
    kd::BuildScratch scratch;
  };
  std::vector<SubtreeTask> subtree_tasks;
  double rebuild_duplication = 0;
  std::size_t rebuild_cells = 0;
};

KdPartition::KdPartition(std::uint32_t cell_limit, float x_split_weight, CellCost cell_cost)
    : cell_limit_(cell_limit),
      x_split_weight_(x_split_weight),
      cell_cost_(std::move(cell_cost)),
      state_(std::make_unique<State>()) {
  if (cell_limit < 2) throw InvalidInput("cell limit must be >= 2 (got " + std::to_string(cell_limit) + ")");
  if (!(x_split_weight > 0) || !(x_split_weight <= 1e6f))
    throw InvalidInput("x split weight must be positive and finite (got " + std::to_string(x_split_weight) + ")");
}
KdPartition::~KdPartition() = default;
KdPartition::KdPartition(KdPartition&&) noexcept = default;
KdPartition& KdPartition::operator=(KdPartition&&) noexcept = default;

void KdPartition::set_rebuild_budget(std::uint32_t entries) {
  if (entries < 2) throw InvalidInput("rebuild budget must be >= 2 entries (got " + std::to_string(entries) + ")");
  rebuild_budget_ = entries;
}

void KdPartition::reset() {
  nodes_.clear();
  state_->rebuilding = false;
  state_->rebuild_queue.clear();
  state_->deferred = false;
  state_->split_pending = false;
}

namespace {
// The most objects a frame (or a reserve) may hold (kNoHome is the
// all-ones id).
static_assert(kMaxFrameObjects < kNoHome);
void check_object_count(std::size_t objects) {
  if (objects > kMaxFrameObjects)
    throw CapacityExceeded("k-d partition: " + std::to_string(objects) + " objects: at most " +
                           std::to_string(kMaxFrameObjects) + " (2^32 - 2) per frame");
}
}  // namespace

void KdPartition::reserve(std::size_t objects) {
  check_object_count(objects);
  // What a build of `objects` objects and the frames after it keep: the
  // build's two working buffers (next_entries and latest, lent to it as a
  // and b: the tasks' inputs and slots, then this frame's and the next
  // frame's cells) at the build's room, the old entries' room (the next
  // frame's `latest`, one entry an object), and the per-object records.
  // Every page past a buffer's contents is written once, from every worker
  // (prefault_pages): the build then finds them resident instead of
  // faulting each one in. The contents (a tree kept from earlier frames)
  // are left as they are.
  State& s = *state_;
  const std::size_t room = kd::build_room(objects);
  auto provide = [](auto& buffer, std::size_t capacity, std::size_t touched) {
    buffer.reserve(capacity);
    if (touched > buffer.size())
      prefault_pages(buffer.data() + buffer.size(), (touched - buffer.size()) * sizeof(*buffer.data()));
  };
  provide(s.next_entries, room, room);
  provide(s.latest, room, room);
  provide(s.entries, room, objects);
  provide(s.home, objects, objects);
  provide(s.prev, objects, objects);
  provide(s.margin, objects, objects);
}

void KdPartition::update(const BoxArray& boxes) {
  if (!begin_update(boxes, false)) return;
  refresh_cells();
  finish_update();
}

bool KdPartition::begin_update(const BoxArray& boxes, bool allow_oversized) {
  check_object_count(boxes.size());
  State& s = *state_;
  if (s.deferred) throw std::logic_error("k-d partition: begin_update before the last frame's finish_update");
  stats_.rebuilt = false;
  stats_.merges = 0;
  stats_.splits = 0;
  stats_.rebuilt_subtrees = 0;
  stats_.rebuilt_entries = 0;
  s.frame_objects = static_cast<std::uint32_t>(boxes.size());
  if (nodes_.empty()) {
    rebuild(boxes);
    end_frame();
    return false;
  }
  maintain(boxes);
  if (allow_oversized || !s.may_outgrow) {
    s.deferred = true;
    entries_ = s.next_entries.data();  // cell(c) shows each cell once refresh_cell(c) wrote it
    stats_.entries = s.cell_offsets.back();
    stats_.cells = static_cast<std::uint32_t>(leaf_nodes_.size());
    return true;
  }
  // A cell may outgrow the limit: every cell now, then the splits.
  refresh_cells();
  s.entries.swap(s.next_entries);
  entries_ = s.entries.data();
  if (split_oversized()) number_leaves();
  end_frame();
  return false;
}

void KdPartition::finish_update() {
  State& s = *state_;
  if (!s.deferred) throw std::logic_error("k-d partition: finish_update without begin_update");
  s.deferred = false;
  s.entries.swap(s.next_entries);
  entries_ = s.entries.data();
  s.split_pending = false;
  for (std::uint32_t c = 0; c < leaf_nodes_.size(); ++c)
    s.split_pending |= cell_size(c) > cell_limit_ && s.leaf_depth[c] < kMaxDepth;
  end_frame();
}

void KdPartition::end_frame() {
  compute_stats(state_->frame_objects);
  State& s = *state_;
  if (stats_.rebuilt || s.round_done) {
    s.rebuild_duplication = stats_.duplication;
    s.rebuild_cells = leaf_nodes_.size();
    if (stats_.rebuilt) s.split_pending = false;
    s.round_done = false;
  } else if (!s.rebuilding && degraded()) {
    // Decided now, done over the next frames (rebuild_step).
    plan_rebuild();
  }
}

void KdPartition::rebuild(const BoxArray& boxes) {
  State& s = *state_;
  const std::size_t n = boxes.size();
  s.home.resize(n);
  s.prev.resize(n);
  s.margin.resize(n);  // set by the build for objects in several cells (the others' is never read unmasked)
  s.objects = n;
  const kd::SplitRule rule{cell_limit_, x_split_weight_, &cell_cost_};
  // The next frame's entry buffer and the per-object entries serve as the
  // build's scratch: the pages the next frame needs are touched once.
  s.build.a = &s.next_entries;
  s.build.b = &s.latest;
  kd::build_tree(boxes, rule, s.build, nodes_, s.entries, s.home.data(), s.prev.data(), s.margin.data());
  // Now `entries` is buffer a, next_entries the old entries' room (untouched
  // on the first frame) and latest buffer b, touched by the routing pass and
  // the tasks' slots (44 MB at 1,024,000 paper objects: 1.4 entries an
  // object). The next frame writes next_entries (the cells: ~1.29 entries an
  // object) and latest (one an object): b serves the cells, so the first maintained
  // frame's fresh pages are latest's 32 bytes an object, not the cells' 41
  // (paper 1,024,000: 16 fresh 2 MiB pages instead of 21), and b's touched
  // pages past one entry an object are not kept idle as latest's room. Cells
  // of a pair-dense scene (~2.3 entries an object) outgrow b: it is freed
  // when next_entries grows, and latest takes its pages (the peak of frames
  // 0-1 of clustered 1,000,000: 774 MB with b kept as latest, 757 MB so).
  s.latest.swap(s.next_entries);
  s.next_entries.clear();  // b's contents are dead: never copied should it have to grow
  // The next frame writes latest for every object; its pages are faulted in
  // here, by all workers, so that the first maintained frame touches no
  // fresh memory at all: when the host has reclaimed free memory, 32 MB of
  // fresh pages made that frame (paper 1,024,000) three times a steady one,
  // where the build frame pays a few per cent more. On a later rebuild
  // latest is last frame's and already resident: one write per page.
  s.latest.resize(n);
  prefault_pages(s.latest.data(), n * sizeof(CellEntry));
  s.rebuilding = false;
  s.rebuild_queue.clear();
  retained::trim(nodes_);  // a past peak of splits
  entries_ = s.entries.data();
  number_leaves();
  stats_.rebuilt = true;
}

void KdPartition::maintain(const BoxArray& boxes) {
  State& s = *state_;
  const std::size_t n = boxes.size();
  // A cell the last frame left over the limit (deferred refresh) is split
  // first, over last frame's boxes and ids (as it would have been then).
  if (s.split_pending) {
    s.split_pending = false;
    if (split_oversized()) number_leaves();
  }
  // A spread rebuild's share of this frame, over last frame's cells (before
  // objects are appended or removed: every id in a cell has a home).
  if (s.rebuilding) rebuild_step();
  if (n != s.objects) {  // objects appended (no home yet) or removed at the end
    s.home.resize(n);
    s.prev.resize(n);
    s.margin.resize(n);
    for (std::size_t i = s.objects; i < n; ++i) {
      s.home[i] = kNoHome;
      s.prev[i] = {};  // read (and masked out) by find_crossings' first pass
      s.margin[i] = 0;
    }
    s.objects = n;
  }
  merge_sparse();
  number_leaves();
  find_crossings(boxes);
  bucket_additions();
  lay_out_cells();
}

void KdPartition::merge_sparse() {
  // Sibling leaves that together held few objects last frame become one leaf
  // (their nodes stay unused until the next rebuild). The merged cell's
  // entries are the two lists merged in (min x, id) order, objects that were
  // in both kept once; objects homed at either leaf are homed at the parent.
  State& s = *state_;
  std::vector<std::uint32_t> stack{0};
  while (!stack.empty()) {
    const std::uint32_t p = stack.back();
    stack.pop_back();
    KdTreeNode& nd = nodes_[p];
    if (nd.axis < 0) continue;
    const std::uint32_t l = nd.child, r = nd.child + 1;
    if (nodes_[l].axis < 0 && nodes_[r].axis < 0) {
      const std::uint32_t ls = nodes_[l].size, rs = nodes_[r].size;
      const bool merge = cell_cost_ ? (ls + rs <= cell_limit_ && cell_cost_(ls + rs) <= cell_cost_(ls) + cell_cost_(rs))
                                    : ls + rs <= cell_limit_ / kMergeFraction;
      if (merge) {
        const CellEntry* a = s.entries.data() + nodes_[l].first;
        const CellEntry* b = s.entries.data() + nodes_[r].first;
        s.merged.clear();
        std::uint32_t i = 0, j = 0;
        while (i < ls || j < rs) {
          if (j == rs || (i < ls && kd::entry_less(a[i], b[j]))) {
            s.merged.push_back(a[i++]);
          } else if (i < ls && a[i].id == b[j].id) {  // in both: once
            s.merged.push_back(a[i++]);
            ++j;
          } else {
            s.merged.push_back(b[j++]);
          }
        }
        const std::size_t objects = s.home.size();  // ids past it were removed this frame
        for (std::uint32_t k = 0; k < ls; ++k)
          if (a[k].id < objects && s.home[a[k].id] == l) s.home[a[k].id] = p;
        for (std::uint32_t k = 0; k < rs; ++k)
          if (b[k].id < objects && s.home[b[k].id] == r) s.home[b[k].id] = p;
        nd.axis = -1;
        nd.first = static_cast<std::uint32_t>(s.entries.size());
        nd.size = static_cast<std::uint32_t>(s.merged.size());
        s.entries.append(s.merged.data(), s.merged.size());
        ++stats_.merges;
      }
      continue;
    }
    stack.push_back(nd.child);
    stack.push_back(nd.child + 1);
  }
  entries_ = s.entries.data();
}

void KdPartition::number_leaves() {
  State& s = *state_;
  leaf_nodes_.clear();
  regions_.clear();
  s.leaf_depth.clear();
  s.node_regions.resize(nodes_.size());
  s.node_seen.resize(nodes_.size());
  s.node_depth.resize(nodes_.size());
  ++s.seen_stamp;
  s.live_nodes = 0;
  struct Item {
    std::uint32_t node;
    CellRegion region;
    std::uint32_t depth;
  };
  std::vector<Item> stack;
  stack.push_back({0, CellRegion::everything(), 0});
  stats_.depth = 0;
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    KdTreeNode& nd = nodes_[it.node];
    ++s.live_nodes;
    stats_.depth = std::max(stats_.depth, it.depth);
    s.node_regions[it.node] = it.region;
    s.node_seen[it.node] = s.seen_stamp;
    s.node_depth[it.node] = it.depth;
    if (nd.axis < 0) {
      nd.leaf = static_cast<std::uint32_t>(leaf_nodes_.size());
      leaf_nodes_.push_back(it.node);
      regions_.push_back(it.region);
      s.leaf_depth.push_back(it.depth);
      continue;
    }
    Item l = it, r = it;
    l.node = nd.child;
    r.node = nd.child + 1;
    l.region.hi[nd.axis] = nd.split;
    r.region.lo[nd.axis] = nd.split;
    l.depth = r.depth = it.depth + 1;
    stack.push_back(r);  // left is processed first: DFS order, left to right
    stack.push_back(l);
  }
  // Every split checks the depth, so traversals may use fixed stacks.
  if (stats_.depth > kMaxDepth) throw std::logic_error("k-d partition deeper than kMaxDepth");
}

void KdPartition::find_crossings(const BoxArray& boxes) {
  // Per object: if its box is still inside its home leaf, nothing changes.
  // Otherwise its new cells are found by a descent (from its home when the
  // box is still inside the home's region, else from the root) and the cells
  // it was not in last frame get an addition; the cells it left drop it in
  // refresh_cells. Last frame's cells: its home leaf, or (homed at an inner
  // node) the leaves its previous box reached.
  State& s = *state_;
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::uint32_t chunks = (n + kChunkObjects - 1) / kChunkObjects;
  if (s.chunk_adds.size() < chunks) s.chunk_adds.resize(chunks);
  s.chunk_adds.resize(chunks);
  const KdTreeNode* nodes = nodes_.data();
  const CellRegion* node_regions = s.node_regions.data();
  std::uint32_t* home = s.home.data();
  StoredBox* prev = s.prev.data();
  float* margin = s.margin.data();
  s.latest.resize(n);
  CellEntry* latest = s.latest.data();
  const float* const lanes[6] = {boxes.min(0), boxes.min(1), boxes.min(2), boxes.max(0), boxes.max(1), boxes.max(2)};
  auto chunk = [&, nodes, node_regions, home, prev, margin, latest](std::uint32_t c) {
    // Pointers by value and the lanes copied: the entry stores below could
    // alias anything reached through a reference (reloads on every object).
    const float* const l0 = lanes[0], *const l1 = lanes[1], *const l2 = lanes[2];
    const float* const l3 = lanes[3], *const l4 = lanes[4], *const l5 = lanes[5];
    std::vector<std::uint64_t>& adds = s.chunk_adds[c];
    adds.clear();
    std::array<std::uint32_t, kMaxDepth + 1> stack;
    const std::uint32_t begin = c * kChunkObjects, end = std::min(n, (c + 1) * kChunkObjects);
    std::vector<std::uint32_t>& mover_list = s.movers.local();
    mover_list.resize(kChunkObjects);
    std::uint32_t* const movers = mover_list.data();
    // Pass 1, branch-free over every object: this frame's entry, and whether
    // the object is quiet (its cells cannot have changed): still inside its
    // home leaf, or, homed at an inner node (in several cells), still inside
    // the home's region with no face moved by half the margin of its last
    // descent (then every plane test of that descent comes out the same,
    // and so do its cells; half: float rounding). Both tests are computed
    // for every object: a branch on the kind of object mispredicted for
    // about one object in four, and the previous boxes, read for every
    // object, stream in sequentially instead of missing one by one. (The
    // previous box and margin of an object in one cell are stale or never
    // written: read, but masked out by `leaf`.)
    std::uint32_t moving = 0;
    for (std::uint32_t i = begin; i < end; ++i) {
      const Box6 box = {{l0[i], l1[i], l2[i], l3[i], l4[i], l5[i]}};
      const float* b = box.b;
      latest[i] = make_entry(box, i);  // one cache line per object for refresh_cells' gather
      const std::uint32_t h = home[i];
      const std::uint32_t at = h == kNoHome ? 0 : h;
      const bool in = inside(b, node_regions[at]);
      const bool leaf = nodes[at].axis < 0;
      const StoredBox& p = prev[i];
      // Started from the x faces' distances, not from 0: GCC turns max(0, d)
      // into a branch, and on the never-written previous box of an object in
      // one cell that branch is a jump on uninitialised memory (memcheck
      // reports it in every program that links us); every other max here
      // is a maxss.
      float moved = std::max(std::abs(b[0] - p.min[0]), std::abs(b[3] - p.max[0]));
      for (int a = 1; a < 3; ++a)
        moved = std::max(moved, std::max(std::abs(b[a] - p.min[a]), std::abs(b[3 + a] - p.max[a])));
      const bool quiet = (h != kNoHome) & in & (leaf | (moved < 0.5f * margin[i]));
      movers[moving] = i;
      moving += !quiet;
    }
    // Pass 2, the others: a descent, from the home when the box is still
    // inside the home's region, else from the root.
    for (std::uint32_t k = 0; k < moving; ++k) {
      const std::uint32_t i = movers[k];
      const CellEntry& e = latest[i];
      const float b[6] = {e.min[0], e.min[1], e.min[2], e.max[0], e.max[1], e.max[2]};
      const std::uint32_t h = home[i];
      const std::uint32_t start = h != kNoHome && inside(b, node_regions[h]) ? h : 0;
      const bool was_leaf = h != kNoHome && nodes[h].axis < 0;
      float old[6] = {};
      if (h != kNoHome && !was_leaf) {
        const StoredBox& p = prev[i];
        for (int a = 0; a < 3; ++a) old[a] = p.min[a], old[3 + a] = p.max[a];
      }
      std::uint32_t top = 0, fork = kNoHome;
      float m = std::numeric_limits<float>::infinity();
      std::uint32_t node = start;
      while (true) {
        while (nodes[node].axis >= 0) {
          const KdTreeNode& nd = nodes[node];
          const bool left = b[nd.axis] < nd.split;
          const bool right = b[3 + nd.axis] >= nd.split;
          m = std::min(m, std::min(std::abs(b[nd.axis] - nd.split), std::abs(b[3 + nd.axis] - nd.split)));
          // Branch-free: a box straddling the plane pushes the right child
          // (the stack's slot at `top` is always writable: top <= depth) and
          // the first such node is the new home.
          const bool both = left & right;
          stack[top] = nd.child + 1;
          top += both;
          fork = both & (fork == kNoHome) ? node : fork;
          node = nd.child + (left ? 0u : 1u);
        }
        const bool was = h == kNoHome ? false : was_leaf ? node == h : overlaps(old, node_regions[node]);
        if (!was) adds.push_back((std::uint64_t{nodes[node].leaf} << 32) | i);
        if (fork == kNoHome) fork = node;  // one cell only: its leaf
        if (top == 0) break;
        node = stack[--top];
      }
      home[i] = fork;
      if (nodes[fork].axis >= 0) {
        prev[i] = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
        margin[i] = m;
      }
    }
  };
  static_assert(sizeof(StoredBox) == 6 * sizeof(float));
  if (chunks <= 1) {
    for (std::uint32_t c = 0; c < chunks; ++c) chunk(c);
  } else {
    detail::parallel_for_each(chunks, [&](std::size_t c) { chunk(static_cast<std::uint32_t>(c)); });
  }
}

void KdPartition::bucket_additions() {
  // Counting sort of the additions by cell; stable, so each cell's come in
  // increasing id order.
  State& s = *state_;
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  s.add_offsets.assign(cells + 1, 0);
  std::size_t total = 0;
  for (const auto& adds : s.chunk_adds) {
    total += adds.size();
    for (std::uint64_t a : adds) ++s.add_offsets[(a >> 32) + 1];
  }
  for (std::uint32_t c = 0; c < cells; ++c) s.add_offsets[c + 1] += s.add_offsets[c];
  s.add_ids.resize(total);
  std::vector<std::uint32_t>& cursor = s.sizes;  // scratch
  cursor.assign(s.add_offsets.begin(), s.add_offsets.end() - 1);
  for (const auto& adds : s.chunk_adds)
    for (std::uint64_t a : adds) s.add_ids[cursor[a >> 32]++] = static_cast<std::uint32_t>(a);
  retained::trim(s.add_ids);
  for (auto& adds : s.chunk_adds) retained::trim(adds);
}

void KdPartition::lay_out_cells() {
  // Where each cell goes in the next buffer: room for its members and its
  // additions (an upper bound: some members leave).
  State& s = *state_;
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  s.cell_offsets.resize(cells + 1);
  std::size_t total = 0;
  s.may_outgrow = false;
  for (std::uint32_t c = 0; c < cells; ++c) {
    s.cell_offsets[c] = total;
    const std::size_t need = nodes_[leaf_nodes_[c]].size + (s.add_offsets[c + 1] - s.add_offsets[c]);
    s.may_outgrow |= need > cell_limit_ && s.leaf_depth[c] < kMaxDepth;
    total += need;
  }
  s.cell_offsets[cells] = total;
  if (total > std::numeric_limits<std::uint32_t>::max() / 2)
    throw CapacityExceeded("k-d partition: more than 2^31 cell entries (" + std::to_string(total) + ")");
  s.next_entries.resize(total);
}

void KdPartition::refresh_cells() {
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  detail::parallel_for(cells, 4, [&](std::size_t begin, std::size_t end) {
    for (std::size_t c = begin; c != end; ++c) refresh_cell(static_cast<std::uint32_t>(c));
  });
}

std::span<const CellEntry> KdPartition::refresh_cell(std::uint32_t c) {
  // The cell, into the next buffer: its members with this frame's boxes,
  // minus those that no longer reach its region, in repaired min-x order,
  // plus its additions merged in.
  State& s = *state_;
  KdTreeNode& leaf = nodes_[leaf_nodes_[c]];
  CellEntry* dst = s.next_entries.data() + s.cell_offsets[c];
  std::uint32_t k =
      keep_members(s.entries.data() + leaf.first, leaf.size, s.latest.data(), s.frame_objects, regions_[c], dst);
  insertion_sort(dst, k);
  const std::uint32_t a0 = s.add_offsets[c], m = s.add_offsets[c + 1] - a0;
  const CellEntry* latest = s.latest.data();
  for (std::uint32_t e = 0; e < m; ++e) dst[k + e] = latest[s.add_ids[a0 + e]];
  insertion_sort(dst + k, m);
  if (m > 0 && k > 0) merge_tail(dst, k, m, s.merge_scratch.local());  // (the thread's scratch looked up only when needed)
  leaf.first = static_cast<std::uint32_t>(s.cell_offsets[c]);
  leaf.size = k + m;
  return {dst, leaf.size};
}

bool KdPartition::split_oversized() {
  // A leaf over the limit is split in place: its entries (already this
  // frame's, sorted) go through a subtree built over them, appended to the
  // entry buffer; objects homed at the leaf get their home in the subtree.
  State& s = *state_;
  const kd::SplitRule rule{cell_limit_, x_split_weight_, &cell_cost_};
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  for (std::uint32_t cell = 0; cell < cells; ++cell) {
    const std::uint32_t leaf = leaf_nodes_[cell];
    if (nodes_[leaf].size <= cell_limit_ || s.leaf_depth[cell] >= kMaxDepth) continue;
    kd::SubtreeBuilder& b = s.splitter;
    b.build(s.entries.data() + nodes_[leaf].first, nodes_[leaf].size, s.leaf_depth[cell], rule, true,
            s.split_scratch);
    if (b.nodes.size() == 1) continue;  // could not split: entries stay in place
    graft_subtree(nodes_, s.entries, b, leaf, [&](CellEntry& e, std::uint32_t global, std::uint32_t base) {
      // New planes: the object's next frame descends, and its cells are
      // now those of this frame's box (the one the split routed).
      s.margin[e.id] = 0;
      if (s.home[e.id] != leaf) s.prev[e.id] = {{e.min[0], e.min[1], e.min[2]}, {e.max[0], e.max[1], e.max[2]}};
      if (!(e.build_tag & kd::kNotOwner) && s.home[e.id] == leaf) {
        const bool forked = (e.build_tag & kd::kForkMask) != kd::kNoFork;
        s.home[e.id] = forked ? kd::fork_node(e.build_tag, leaf, base) : global;
        if (forked) s.prev[e.id] = {{e.min[0], e.min[1], e.min[2]}, {e.max[0], e.max[1], e.max[2]}};
      }
    });
    ++stats_.splits;
  }
  entries_ = s.entries.data();
  return stats_.splits > 0;
}

void KdPartition::compute_stats(std::size_t objects) {
  State& s = *state_;
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  stats_.cells = cells;
  stats_.oversized_cells = 0;
  s.sizes.resize(cells);
  std::uint64_t entries = 0;
  for (std::uint32_t c = 0; c < cells; ++c) {
    s.sizes[c] = cell_size(c);
    entries += s.sizes[c];
    if (s.sizes[c] > cell_limit_) ++stats_.oversized_cells;
  }
  stats_.entries = entries;
  if (cells) {
    const auto [lo, hi] = std::minmax_element(s.sizes.begin(), s.sizes.end());
    stats_.min_cell = *lo;
    stats_.max_cell = *hi;
    std::nth_element(s.sizes.begin(), s.sizes.begin() + cells / 2, s.sizes.end());
    stats_.median_cell = s.sizes[cells / 2];
  }
  stats_.duplication = objects > 0 ? static_cast<double>(entries) / static_cast<double>(objects) : 1.0;
}

bool KdPartition::degraded() const {
  const State& s = *state_;
  return stats_.duplication > kDuplicationGrowth * s.rebuild_duplication + kDuplicationSlack ||
         leaf_nodes_.size() > kCellGrowth * s.rebuild_cells + kCellSlack ||
         nodes_.size() > kDeadNodeFactor * s.live_nodes + kDeadNodeSlack;
}

namespace {
// Entries in the leaves under node i (sizes[k] for every node k under it).
std::uint64_t subtree_entries(const std::vector<KdTreeNode>& nodes, std::uint32_t i, std::vector<std::uint64_t>& sizes) {
  const KdTreeNode& nd = nodes[i];
  sizes[i] = nd.axis < 0 ? nd.size
                         : subtree_entries(nodes, nd.child, sizes) + subtree_entries(nodes, nd.child + 1, sizes);
  return sizes[i];
}
}  // namespace

void KdPartition::plan_rebuild() {
  // The subtrees of the spread rebuild: the highest inner nodes holding at
  // most a frame's share of entries (kRebuildFrames, the budget; two full
  // cells at least), left to right. Their planes are rebuilt; the planes above them
  // (a few levels: the paper scene's 1.3 M entries make subtrees of at most
  // 16,384, six or seven levels down) are kept. A leaf above the
  // subtrees stays as it is (the maintenance splits it when over-full).
  State& s = *state_;
  std::vector<std::uint64_t> sizes(nodes_.size(), 0);
  const std::uint64_t total = subtree_entries(nodes_, 0, sizes);  // recursion depth <= kMaxDepth
  const std::uint64_t share = std::min<std::uint64_t>(rebuild_budget_, total / kRebuildFrames);
  // Subtrees of half a share: a frame's share is usually two or more of
  // them, built in parallel.
  const std::uint64_t task = std::max<std::uint64_t>(share / 2, 2ull * cell_limit_);
  s.rebuild_share = std::max(share, task);
  s.rebuild_queue.clear();
  s.rebuild_sizes.clear();
  s.rebuild_cursor = 0;
  std::vector<std::uint32_t> stack{0};
  while (!stack.empty()) {
    const std::uint32_t i = stack.back();
    stack.pop_back();
    const KdTreeNode& nd = nodes_[i];
    if (nd.axis < 0) continue;
    if (sizes[i] <= task) {
      s.rebuild_queue.push_back(i);
      s.rebuild_sizes.push_back(sizes[i]);
      continue;
    }
    stack.push_back(nd.child + 1);
    stack.push_back(nd.child);
  }
  s.rebuilding = true;
}

void KdPartition::rebuild_step() {
  // This frame's share: queued subtrees while their entries (as planned)
  // fit the share (at least one). A queued node no longer reachable (merged
  // away) or now a leaf is skipped. The subtrees are built in parallel, each
  // by itself (gather, sort, serial build: the same result on any thread),
  // then spliced into the tree one after the other in queue order. After
  // the last one the node array is compacted (every rebuilt subtree left its
  // old nodes behind).
  State& s = *state_;
  std::uint64_t planned = 0;
  s.batch.clear();
  while (s.rebuild_cursor < s.rebuild_queue.size() &&
         (planned == 0 || planned + s.rebuild_sizes[s.rebuild_cursor] <= s.rebuild_share)) {
    planned += s.rebuild_sizes[s.rebuild_cursor];
    const std::uint32_t r = s.rebuild_queue[s.rebuild_cursor++];
    if (r >= s.node_seen.size() || s.node_seen[r] != s.seen_stamp || nodes_[r].axis < 0) continue;
    s.batch.push_back(r);
  }
  if (!s.batch.empty()) {
    // Which old node belongs to which subtree (homes in it are renewed).
    s.node_task.assign(nodes_.size(), kNoHome);
    std::vector<std::uint32_t> stack;
    for (std::uint32_t k = 0; k < s.batch.size(); ++k) {
      stack.assign(1, s.batch[k]);
      while (!stack.empty()) {
        const std::uint32_t i = stack.back();
        stack.pop_back();
        s.node_task[i] = k;
        if (nodes_[i].axis >= 0) {
          stack.push_back(nodes_[i].child + 1);
          stack.push_back(nodes_[i].child);
        }
      }
    }
    if (s.subtree_tasks.size() < s.batch.size()) s.subtree_tasks.resize(s.batch.size());
    const auto count = static_cast<std::uint32_t>(s.batch.size());
    auto build = [&](std::uint32_t k) { build_subtree(k); };
    if (count == 1) build(0);
    else detail::parallel_for_each(count, [&](std::size_t k) { build(static_cast<std::uint32_t>(k)); });
    std::uint64_t done = 0;
    for (std::uint32_t k = 0; k < count; ++k) done += splice_subtree(k);
    stats_.rebuilt_subtrees = count;
    stats_.rebuilt_entries = done;
  }
  if (s.rebuild_cursor == s.rebuild_queue.size()) {
    s.rebuilding = false;
    s.round_done = true;
    s.rebuild_queue.clear();
    s.rebuild_sizes.clear();
    compact_nodes();
  }
  number_leaves();
}

void KdPartition::build_subtree(std::uint32_t k) {
  // Subtree k's objects, once each, in (min x, id) order (each leaf is in
  // that order; an object in several of its leaves has the same entry in
  // each), built by a serial SubtreeBuilder. Reads the tree, writes only
  // task k's buffers.
  State& s = *state_;
  State::SubtreeTask& t = s.subtree_tasks[k];
  const std::uint32_t root = s.batch[k];
  t.gathered.clear();
  std::array<std::uint32_t, 2 * kMaxDepth + 2> stack;  // a DFS holds at most one sibling per level
  std::uint32_t top = 0;
  stack[top++] = root;
  while (top > 0) {
    const KdTreeNode& nd = nodes_[stack[--top]];
    if (nd.axis < 0) {
      const CellEntry* e = s.entries.data() + nd.first;
      t.gathered.insert(t.gathered.end(), e, e + nd.size);
    } else {
      stack[top++] = nd.child + 1;
      stack[top++] = nd.child;
    }
  }
  std::sort(t.gathered.begin(), t.gathered.end(), kd::entry_less);
  t.gathered.erase(std::unique(t.gathered.begin(), t.gathered.end(),
                               [](const CellEntry& a, const CellEntry& b) { return a.id == b.id; }),
                   t.gathered.end());
  retained::trim(t.gathered);
  const kd::SplitRule rule{cell_limit_, x_split_weight_, &cell_cost_};
  t.builder.build(t.gathered.data(), static_cast<std::uint32_t>(t.gathered.size()), s.node_depth[root], rule, true,
                  t.scratch);
}

std::uint64_t KdPartition::splice_subtree(std::uint32_t k) {
  // Subtree k, built, replaces the old one (appended like a split leaf's).
  // Objects homed in the old subtree get their home in the new one; every
  // object in it descends on the next frame (margin 0: new planes) from a
  // previous box equal to the one its current cells were made from.
  State& s = *state_;
  const std::uint32_t root = s.batch[k];
  kd::SubtreeBuilder& b = s.subtree_tasks[k].builder;
  const std::size_t old_nodes = s.node_task.size();
  graft_subtree(nodes_, s.entries, b, root, [&](CellEntry& e, std::uint32_t global, std::uint32_t base) {
    s.margin[e.id] = 0;
    s.prev[e.id] = {{e.min[0], e.min[1], e.min[2]}, {e.max[0], e.max[1], e.max[2]}};
    const std::uint32_t h = s.home[e.id];
    if (!(e.build_tag & kd::kNotOwner) && h < old_nodes && s.node_task[h] == k) {
      const bool forked = (e.build_tag & kd::kForkMask) != kd::kNoFork;
      s.home[e.id] = forked ? kd::fork_node(e.build_tag, root, base) : global;
    }
  });
  entries_ = s.entries.data();
  return b.output_size();
}

void KdPartition::compact_nodes() {
  // Reachable nodes only, breadth first (children stay adjacent), homes
  // renumbered.
  State& s = *state_;
  std::vector<std::uint32_t> renumber(nodes_.size(), kNoHome);
  std::vector<KdTreeNode> kept;
  kept.reserve(s.live_nodes + 2);
  kept.push_back(nodes_[0]);
  renumber[0] = 0;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    if (kept[i].axis < 0) continue;
    const std::uint32_t c = kept[i].child;
    const auto at = static_cast<std::uint32_t>(kept.size());
    kept[i].child = at;
    renumber[c] = at;
    renumber[c + 1] = at + 1;
    kept.push_back(nodes_[c]);
    kept.push_back(nodes_[c + 1]);
  }
  std::uint32_t* home = s.home.data();
  for (std::size_t i = 0; i < s.objects; ++i)
    if (home[i] != kNoHome) home[i] = renumber[home[i]];
  nodes_.swap(kept);
}

}  // namespace hbp
