// SPDX-License-Identifier: MIT
#include "partition/kd_build.hpp"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "hbp/error.hpp"
#include "geometry/centre.hpp"
#include "partition/kd_sampled_build.hpp"
#include "support/parallel_for.hpp"
#include "support/radix_sort.hpp"

namespace hbp::kd {

namespace {

// Nodes with more entries than this choose their split from a fixed strided
// sample of kSplitSamples entries (the median of the sample, about a percent
// from the true median: cells of ~600 differ by a few entries); smaller ones
// use every entry. Exact medians of larger nodes (an nth_element over every
// centre) would be the largest part of the subtree tasks, while a sampled
// median changes the cells and the duplication by a fraction of a percent
// (a few nodes just under the limit stay unsplit).
constexpr std::uint32_t kExactSplitMax = 1u << 10;
constexpr std::uint32_t kSplitSamples = 1u << 10;
// The parallel build's top levels (from a sample, kd_sampled_build.cpp) end
// at nodes of about this many entries (about 1 MB: it fits the cache); each
// such subtree is then built exactly as one serial task.
constexpr std::uint32_t kTaskEntries = 1u << 15;
// A task's output slot holds its input plus 1/kTaskSlotHeadroom of it plus
// kTaskSlack entries (the copies its own planes add; paper scene: 1.15x;
// the pair-dense scenes' tasks 1.6-1.85x: the rest spills, see build_into).
constexpr std::uint32_t kTaskSlotHeadroom = 4;
constexpr std::uint32_t kTaskSlack = 256;
// Nodes of at least this many entries count their split's sides in parallel.
constexpr std::uint32_t kParallelCountMin = 1u << 18;
// The engine-cost rule splits a node under the limit only when the children
// cost below this fraction of the parent.
constexpr double kCostSplitGain = 0.95;
// The weighted axis gives way when it puts this many times more entries into
// its children than the widest unweighted axis would.
constexpr double kWeightedDuplicationLimit = 1.05;

float centre(const CellEntry& e, int a) { return geometry::centre(e.min[a], e.max[a]); }

// The k-th smallest (from 0) of the float_order_keys keys[0..n) as a float
// (keys[n..2n) scratch): a radix select, a byte at a time from the top,
// keeping only the keys in the byte bucket that holds rank k. The same value
// as std::nth_element over the floats (but -0 read as +0, the same plane),
// without its mispredicted partition loops (most of choose_split's time).
float select_key(std::uint32_t* keys, std::uint32_t n, std::uint32_t k) {
  std::uint32_t* from = keys;
  std::uint32_t* to = keys + n;
  std::uint32_t m = n;
  for (int shift = 24; shift >= 0 && m > 1; shift -= 8) {
    std::uint32_t count[256] = {};
    for (std::uint32_t i = 0; i < m; ++i) ++count[(from[i] >> shift) & 0xFFu];
    std::uint32_t bucket = 0;
    while (k >= count[bucket]) k -= count[bucket++];
    if (count[bucket] == m) continue;  // every key has this byte
    std::uint32_t kept = 0;
    for (std::uint32_t i = 0; i < m; ++i) {  // branch-free
      const std::uint32_t x = from[i];
      to[kept] = x;
      kept += ((x >> shift) & 0xFFu) == bucket;
    }
    std::swap(from, to);
    m = kept;
  }
  // Every key left is the same (or one is left): the inverse of float_order_key.
  const std::uint32_t key = from[0];
  return std::bit_cast<float>(key & 0x80000000u ? key & 0x7FFFFFFFu : ~key);
}

// Returns the entries written to each side.
std::pair<std::uint32_t, std::uint32_t> partition_range(const CellEntry* e, std::uint32_t n, const Split& s,
                                                        std::uint32_t fork_tag, CellEntry* left, CellEntry* right);

}  // namespace

bool choose_split(const CellEntry* e, std::uint32_t n, std::uint32_t depth, const SplitRule& rule,
                  std::vector<std::uint32_t>& scratch, Split& out, const PartitionTarget* target) {
  const bool over_limit = n > rule.cell_limit;
  const bool by_cost = rule.cell_cost && *rule.cell_cost;
  if ((!over_limit && !by_cost) || n < 4 || depth >= KdPartition::kMaxDepth) return false;

  // The entries the split is chosen from: all, or a fixed strided sample.
  const std::uint32_t samples = n > kExactSplitMax ? kSplitSamples : n;
  auto sample = [&](std::uint32_t k) -> const CellEntry& {
    // (Divided by the constant, not by `samples`: a division per sample
    // was a tenth of choose_split's time.)
    return samples == n ? e[k] : e[static_cast<std::uint64_t>(k) * n / kSplitSamples];
  };

  // Axes ordered by the (weighted) spread of box centres, widest first.
  // The three centres of an entry at once, as 4-lane vectors (GCC/Clang
  // vector extensions: the same float operations per lane as centre(), so
  // the same values; a fifth of the subtree tasks' instructions went to this
  // loop done axis by axis). Lane 3 is max x and the id's bits masked to 0.
  using V4 = float __attribute__((vector_size(16)));
  using I4 = std::int32_t __attribute__((vector_size(16)));
  static_assert(offsetof(CellEntry, min) == 0 && offsetof(CellEntry, max) == 12 && sizeof(CellEntry) == 32);
  const float inf = std::numeric_limits<float>::infinity();
  V4 vlo = {inf, inf, inf, inf}, vhi = {-inf, -inf, -inf, -inf};
  const V4 half = {0.5f, 0.5f, 0.5f, 0.5f};
  const I4 xyz = {-1, -1, -1, 0};
  for (std::uint32_t k = 0; k < samples; ++k) {
    const CellEntry& s = sample(k);
    V4 mn, mx;
    std::memcpy(&mn, &s.min[0], sizeof mn);
    std::memcpy(&mx, &s.max[0], sizeof mx);
    mn = reinterpret_cast<V4>(reinterpret_cast<I4>(mn) & xyz);
    mx = reinterpret_cast<V4>(reinterpret_cast<I4>(mx) & xyz);
    const V4 c = half * mn + half * mx;
    vlo = c < vlo ? c : vlo;  // std::min(lo, c)
    vhi = vhi < c ? c : vhi;  // std::max(hi, c)
  }
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = vlo[a];
    hi[a] = vhi[a];
  }
  int axes[3] = {0, 1, 2};
  auto spread = [&](int a) { return (hi[a] - lo[a]) * (a == 0 ? rule.x_split_weight : 1.0f); };
  std::stable_sort(axes, axes + 3, [&](int x, int y) { return spread(x) > spread(y); });

  // The median split on axis a: false when it does not shrink both halves
  // (or, under the limit, does not lower the summed cost).
  // With a target (over the limit, serial), the first axis tried is counted
  // by partitioning into it; whether the target holds the split `out`.
  bool partitioned = false;
  auto try_axis = [&](int a, Split& s, bool into_target) {
    if (!(hi[a] > lo[a])) return false;
    scratch.resize(2 * std::size_t{samples});
    for (std::uint32_t k = 0; k < samples; ++k) scratch[k] = float_order_key(centre(sample(k), a));
    float split = select_key(scratch.data(), samples, samples / 2);
    if (!(split > lo[a])) split = std::nextafter(lo[a], hi[a]);  // keep the left side non-empty
    std::uint32_t left = 0, right = 0;
    if (n >= kParallelCountMin) {
      // The root and the first levels: counted across threads (integer sums,
      // the same for any thread count).
      using Counts = std::pair<std::uint32_t, std::uint32_t>;
      const Counts c = hbp::detail::parallel_reduce(
          n, kParallelCountMin / 4, Counts{0, 0},
          [&](std::size_t begin, std::size_t end, Counts acc) {
            for (std::size_t i = begin; i != end; ++i) {
              acc.first += e[i].min[a] < split;
              acc.second += e[i].max[a] >= split;
            }
            return acc;
          },
          [](Counts x, Counts y) { return Counts{x.first + y.first, x.second + y.second}; });
      left = c.first;
      right = c.second;
    } else if (into_target) {
      // Counted by the partition itself: each side has room for all n
      // entries and the scratch slot.
      std::tie(left, right) =
          partition_range(e, n, Split{a, split, 0, 0}, target->fork_tag, target->left, target->right);
    } else {
      for (std::uint32_t i = 0; i < n; ++i) {
        left += e[i].min[a] < split;
        right += e[i].max[a] >= split;
      }
    }
    bool accept = left < n && right < n;
    if (accept && !over_limit) {
      // Under the limit: split only if the engine's summed cost drops.
      const KdPartition::CellCost& cost = *rule.cell_cost;
      accept = cost(left) + cost(right) < kCostSplitGain * cost(n);
    }
    if (accept) s = {a, split, left, right};
    return accept;
  };

  for (int a : axes) {
    // Over the limit a split is accepted whenever both sides shrink (nearly
    // always): partition while counting. Under it (the cost rule) most
    // splits are refused: count only.
    partitioned = target && over_limit && n < kParallelCountMin;
    if (!try_axis(a, out, partitioned)) continue;
    // The x weight shapes cells for the sweep, but not at any price: when the
    // axis of widest unweighted spread duplicates clearly fewer objects, it
    // wins (scenes of huge boxes: duplication 38 instead of 4 otherwise).
    // Any split sends every entry at least one way (min <= max), so the
    // other axis's children hold at least n entries: when this split's hold
    // at most kWeightedDuplicationLimit * n, the other cannot win and is not
    // tried (the same choice, for half the work at most nodes of a scene of
    // small boxes).
    if (rule.x_split_weight != 1.0f && double(out.left) + out.right > kWeightedDuplicationLimit * n) {
      int plain = 0;
      for (int b = 1; b < 3; ++b)
        if (hi[b] - lo[b] > hi[plain] - lo[plain]) plain = b;
      Split alt;
      if (plain != a && try_axis(plain, alt, false) &&
          kWeightedDuplicationLimit * (alt.left + alt.right) < double(out.left) + out.right) {
        out = alt;
        partitioned = false;
      }
    }
    if (target && !partitioned) partition_range(e, n, out, target->fork_tag, target->left, target->right);
    return true;
  }
  return false;  // no axis shrinks both halves: an over-full leaf, processed in tiles
}

namespace {

// partition_entries over e[0..n), returning the entries written to each
// side. Branch-free: every entry is written to both cursors and each
// advances only when the entry belongs there (so each side writes one slot
// past its output), a copy going both ways taking its tags by selects. (The
// branches on "goes left" and "goes both ways" mispredicted about every other
// entry: a quarter of the build's samples, perf, PaperRebuild 1,024,000.)
std::pair<std::uint32_t, std::uint32_t> partition_range(const CellEntry* e, std::uint32_t n, const Split& s,
                                                        std::uint32_t fork_tag, CellEntry* left, CellEntry* right) {
  static_assert(kNotOwner == 0x80000000u);
  CellEntry* const left_begin = left;
  CellEntry* const right_begin = right;
  const int a = s.axis;
  const float split = s.split;
  // The entry as two 16-byte halves, its tag lane 3 of the second (set in
  // a register: a 4-byte store into the copy and a 16-byte reload stalled
  // store forwarding).
  using U4 = std::uint32_t __attribute__((vector_size(16)));
  static_assert(offsetof(CellEntry, build_tag) == 28 && sizeof(CellEntry) == 32);
  for (std::uint32_t i = 0; i < n; ++i) {
    const CellEntry& c = e[i];
    U4 lo, hi;
    std::memcpy(&lo, &c, sizeof lo);
    std::memcpy(&hi, reinterpret_cast<const char*>(&c) + 16, sizeof hi);
    const std::uint32_t l = c.min[a] < split;
    const std::uint32_t r = c.max[a] >= split;
    const std::uint32_t both = l & r;
    const std::uint32_t tag = hi[3];
    // A copy going both ways records this node as its first fork (unless an
    // earlier node did); the right copy is never the owner copy.
    const std::uint32_t fresh = both & ((tag & kForkMask) == kNoFork);
    const std::uint32_t mask = 0u - fresh;
    const std::uint32_t left_tag = (tag & ~mask) | (((tag & kNotOwner) | fork_tag) & mask);
    hi[3] = left_tag;
    std::memcpy(left, &lo, sizeof lo);
    std::memcpy(reinterpret_cast<char*>(left) + 16, &hi, sizeof hi);
    left += l;
    hi[3] = left_tag | (both << 31);
    std::memcpy(right, &lo, sizeof lo);
    std::memcpy(reinterpret_cast<char*>(right) + 16, &hi, sizeof hi);
    right += r;
  }
  return {static_cast<std::uint32_t>(left - left_begin), static_cast<std::uint32_t>(right - right_begin)};
}

}  // namespace

void partition_entries(const CellEntry* e, std::uint32_t n, const Split& s, std::uint32_t fork_tag, CellEntry* left,
                       CellEntry* right) {
  partition_range(e, n, s, fork_tag, left, right);
}

void SubtreeBuilder::start(const CellEntry* items, std::uint32_t n, const SplitRule& rule, bool reset_tags,
                           BuildScratch& scratch) {
  rule_ = &rule;
  scratch_ = &scratch;
  nodes.assign(1, KdTreeNode{});
  RawBuffer<CellEntry>& arena = scratch.arena;
  // What the root needs (its copy and its two sides' room); deeper levels
  // grow the stack (RawBuffer grows in place, without a copy), so no address
  // space is held for levels a build does not reach. Shrinks a past peak.
  arena.resize(3 * std::size_t{n} + 2);
  root_items_ = nullptr;
  if (!reset_tags) {
    // The root reads the items where they are (a copy into the arena was
    // an extra read and write of every entry of the build).
    arena.truncate(0);
    root_items_ = items;
    return;
  }
  arena.truncate(n);
  if (n) std::memcpy(arena.data(), items, std::size_t{n} * sizeof(CellEntry));
  for (std::uint32_t i = 0; i < n; ++i) arena[i].build_tag = kNoFork;
}

void SubtreeBuilder::build(const CellEntry* items, std::uint32_t n, std::uint32_t depth, const SplitRule& rule,
                           bool reset_tags, BuildScratch& scratch) {
  out_ = nullptr;
  out_capacity_ = out_size_ = 0;
  entries.resize(n + n / 4);  // about the final size (grows with duplicates); shrinks a past peak
  entries.clear();
  start(items, n, rule, reset_tags, scratch);
  node(0, 0, n, depth);
}

void SubtreeBuilder::build_into(const CellEntry* items, std::uint32_t n, std::uint32_t depth, const SplitRule& rule,
                                BuildScratch& scratch, CellEntry* out, std::size_t out_capacity) {
  out_ = out;
  out_capacity_ = out_capacity;
  out_size_ = 0;
  // No room kept from a past build. A task of a pair-dense scene spills
  // about a third of its output (clustered 1,000,000: 740,000 entries of 60
  // tasks): the spill grows by appends, which a large buffer does in place.
  entries.resize(0);
  start(items, n, rule, false, scratch);
  node(0, 0, n, depth);
}

void SubtreeBuilder::node(std::uint32_t at, std::size_t begin, std::uint32_t n, std::uint32_t depth) {
  RawBuffer<CellEntry>& arena_ = scratch_->arena;
  // Children's segments go on top of the arena stack, dropped when done:
  // room for every entry on each side (choose_split partitions into it),
  // then cut to the sides' sizes.
  const std::size_t children = arena_.size();
  arena_.grow(children + 2 * std::size_t{n} + 2);
  const PartitionTarget target{at | kLocalNode, arena_.data() + children, arena_.data() + children + n + 1};
  const CellEntry* const e = at == 0 && root_items_ ? root_items_ : arena_.data() + begin;
  Split s;
  if (!choose_split(e, n, depth, *rule_, scratch_->centres, s, &target)) {
    arena_.truncate(children);
    KdTreeNode& leaf = nodes[at];
    leaf.axis = -1;
    leaf.size = n;
    if (out_ && out_size_ + n <= out_capacity_) {
      leaf.first = static_cast<std::uint32_t>(out_size_);
      if (n) std::memcpy(out_ + out_size_, e, std::size_t{n} * sizeof(CellEntry));
      out_size_ += n;
    } else {
      leaf.first = static_cast<std::uint32_t>(entries.size()) | (out_ ? kSpilled : 0u);
      entries.append(e, n);
    }
    return;
  }
  const auto child = static_cast<std::uint32_t>(nodes.size());
  nodes[at].axis = s.axis;
  nodes[at].split = s.split;
  nodes[at].child = child;
  nodes.emplace_back();
  nodes.emplace_back();
  arena_.truncate(children + n + 1 + s.right + 1);
  node(child, children, s.left, depth + 1);
  node(child + 1, children + n + 1, s.right, depth + 1);
  arena_.truncate(children);
}

std::size_t build_room(std::size_t objects) { return objects + objects / 2 + kTaskSlack; }

void build_tree(const BoxArray& boxes, const SplitRule& rule, BuildBuffers& buffers, std::vector<KdTreeNode>& nodes,
                RawBuffer<CellEntry>& entries, std::uint32_t* home, StoredBox* prev, float* margin) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const float* src[6] = {boxes.min(0), boxes.min(1), boxes.min(2), boxes.max(0), boxes.max(1), boxes.max(2)};
  RawBuffer<CellEntry>& a = *buffers.a;
  RawBuffer<CellEntry>& b = *buffers.b;
  // Room for the top levels' duplicates and the tasks' output slots, so the
  // buffers neither move nor copy while they grow; their old contents are
  // not needed. `entries` (swapped with a at the end: its storage becomes
  // the next frame's scratch) keeps what it has and grows when used.
  const std::size_t room = build_room(n);
  entries.clear();
  a.clear();
  b.clear();
  a.reserve(room);
  b.reserve(room);
  nodes.assign(1, KdTreeNode{});
  std::vector<BuildTask> frontier;
  if (samples_top_levels(n, kTaskEntries)) {
    // 1-2. The top levels from a sample, every object routed through them
    // once into its tasks' entries in a (kd_sampled_build.cpp).
    build_top_levels(boxes, rule, kTaskEntries, buffers.top, buffers.sample_tree, buffers.scratch.local(), nodes, a, b,
                     frontier);
  } else {
    // 1-2. One task: the objects as entries, sorted by min x (ties by id).
    // The sort keys and their scratch live in the output buffer (free until
    // the end; 16 bytes a key pair within a 32-byte entry).
    static_assert(sizeof(CellEntry) >= 2 * sizeof(std::uint64_t));  // (RawBuffer memory is 64-byte aligned)
    entries.resize(n);
    auto* keys = reinterpret_cast<std::uint64_t*>(entries.data());
    for (std::uint32_t i = 0; i < n; ++i) keys[i] = (std::uint64_t{float_order_key(src[0][i])} << 32) | i;
    keys = radix_sort_keyed_indices(keys, keys + n, n);
    a.resize(n);
    for (std::uint32_t k = 0; k < n; ++k) {
      const auto id = static_cast<std::uint32_t>(keys[k]);
      a[k] = {{src[0][id], src[1][id], src[2][id]}, {src[3][id], src[4][id], src[5][id]}, id, kNoFork};
    }
    frontier.push_back({0, 0, 0, n});
  }
  // 3. One serial subtree per task, in parallel, each writing its leaves
  // into its own slot of buffer b (touched by the top levels already: a
  // buffer of its own per task would be fresh pages, the first frame's
  // largest cost); a task that outgrows its slot spills the rest to its own
  // buffer. Then stitched in task order into `entries`.
  std::vector<SubtreeBuilder>& tasks = buffers.tasks;
  tasks.resize(frontier.size());
  std::vector<std::size_t> slot(frontier.size() + 1, 0);
  for (std::size_t t = 0; t < frontier.size(); ++t)
    slot[t + 1] = slot[t] + frontier[t].n + frontier[t].n / kTaskSlotHeadroom + kTaskSlack;
  b.clear();
  b.resize(slot.back());
  // Largest first, each thread taking the next task when done (a task's
  // result does not depend on who builds it or when): the last task to
  // finish is a small one, where ranges of task indices could leave one
  // thread idle for several tasks.
  std::vector<std::uint32_t> order(frontier.size());
  for (std::uint32_t t = 0; t < order.size(); ++t) order[t] = t;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t x, std::uint32_t y) { return frontier[x].n > frontier[y].n; });
  std::atomic<std::size_t> next{0};
  const auto workers = std::min<std::size_t>(static_cast<std::size_t>(hbp::detail::concurrency()), order.size());
  hbp::detail::parallel_for_each(workers, [&](std::size_t) {
    for (std::size_t k; (k = next.fetch_add(1, std::memory_order_relaxed)) < order.size();) {
      const std::uint32_t t = order[k];
      const BuildTask& it = frontier[t];
      tasks[t].build_into(a.data() + it.begin, it.n, it.depth, rule, buffers.scratch.local(), b.data() + slot[t],
                          slot[t + 1] - slot[t]);
    }
  });
  // Leaves are laid out task after task, each task's in local node order.
  std::vector<std::uint32_t> node_base(tasks.size());
  std::vector<std::size_t> entry_base(tasks.size() + 1, 0);
  std::size_t node_count = nodes.size();  // reserved at once: no copies while growing
  for (const SubtreeBuilder& task : tasks) node_count += task.nodes.size() - 1;
  nodes.reserve(node_count);
  for (std::size_t t = 0; t < tasks.size(); ++t) {
    node_base[t] = static_cast<std::uint32_t>(nodes.size());
    const std::uint32_t root = frontier[t].node;
    const std::vector<KdTreeNode>& local = tasks[t].nodes;
    if (nodes.size() + local.size() > kMaxNodes) throw CapacityExceeded("k-d partition: too many tree nodes");
    std::size_t at = entry_base[t];
    auto remap = [&](KdTreeNode nd) {
      if (nd.axis >= 0) {
        nd.child = node_base[t] + nd.child - 1;
      } else {
        nd.first = static_cast<std::uint32_t>(at);
        at += nd.size;
      }
      return nd;
    };
    nodes[root] = remap(local[0]);
    for (std::size_t k = 1; k < local.size(); ++k) nodes.push_back(remap(local[k]));
    entry_base[t + 1] = entry_base[t] + tasks[t].output_size();
  }
  // Stitched into buffer a (the tasks' inputs, read by now: its pages are
  // touched), which then becomes `entries`: the first frame touches two
  // buffers, not three (fresh pages are its largest cost).
  a.clear();  // not kept if it must grow
  a.resize(entry_base.back());
  hbp::detail::parallel_for_each(tasks.size(), [&](std::size_t t) {
    const std::uint32_t root = frontier[t].node;
    const std::vector<KdTreeNode>& local = tasks[t].nodes;
    const CellEntry* in_slot = b.data() + slot[t];
    const CellEntry* spilled = tasks[t].entries.data();
    CellEntry* to = a.data() + entry_base[t];
    for (std::size_t k = 0; k < local.size(); ++k) {
      if (local[k].axis >= 0) continue;
      const std::uint32_t leaf = k == 0 ? root : node_base[t] + static_cast<std::uint32_t>(k) - 1;
      const std::uint32_t first = local[k].first;
      const CellEntry* from = first & SubtreeBuilder::kSpilled ? spilled + (first & ~SubtreeBuilder::kSpilled)
                                                               : in_slot + first;
      for (std::uint32_t i = 0; i < local[k].size; ++i) {
        CellEntry e = from[i];
        if (!(e.build_tag & kNotOwner)) {  // the object's one owner copy sets its home
          const std::uint32_t fork = (e.build_tag & kForkMask) == kNoFork ? kNoFork : fork_node(e.build_tag, root, node_base[t]);
          home[e.id] = fork == kNoFork ? leaf : fork;
          if (fork != kNoFork) {
            prev[e.id] = {{e.min[0], e.min[1], e.min[2]}, {e.max[0], e.max[1], e.max[2]}};
            margin[e.id] = 0;  // the first maintained frame descends once
          }
        }
        e.build_tag = 0;
        *to++ = e;
      }
    }
  });
  entries.swap(a);
  release_build_scratch(buffers);
}

void release_build_scratch(BuildBuffers& buffers) {
  // Dead once the tree is stitched: the subtree tasks' nodes and spill
  // buffers, the per-thread arenas (the largest: ~3 task inputs touched a
  // thread, 4-5 MB at 2^15 entries), the sample and its tree. Given back
  // now, their pages, which the process has touched already, serve the
  // frame's later allocations (the pair list, then the next frame's
  // `latest`): on our VMs a fresh page costs the host's fault when the host
  // has reclaimed free memory (2.3-2.45 ms a MB on one thread), a page the
  // process just freed does not (0.09 ms a MB; docs/hybrid-system.md, "First
  // frame and rebuilds").
  // Nor is memory held at the build's peak until the next rebuild (the
  // first frame's only, or one after reset()).
  std::vector<SubtreeBuilder>().swap(buffers.tasks);
  buffers.scratch.clear();
  RawBuffer<CellEntry>().swap(buffers.top.sample);
  std::vector<RouteNode>().swap(buffers.top.route);
  RawBuffer<std::uint32_t>().swap(buffers.top.counts);
  std::vector<std::vector<std::uint32_t>>().swap(buffers.top.forked_tasks);
  buffers.top.forked.clear();
  buffers.sample_tree = SubtreeBuilder{};
}

}  // namespace hbp::kd
