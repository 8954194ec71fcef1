#include "partition/kd_sampled_build.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "hbp/error.hpp"
#include "support/radix_sort.hpp"

namespace hbp::kd {

namespace {

// Frames of fewer objects build exactly: the exact build is then a single
// subtree task in the cache anyway.
constexpr std::size_t kSampledBuildMinObjects = std::size_t{1} << 15;
// At most one object in kMaxSampleRate is sampled, and the sample tree's
// cells hold at least kMinSamplesPerCell samples' worth of the limit (a cell
// of 1,024 at rate 32: a leaf of the sample tree holds at most 32 samples,
// the paper scene's ~20, its count estimated to about +-20 %; a cell the
// estimate put under the limit that is over it is split exactly afterwards).
constexpr std::uint32_t kMaxSampleRate = 32;
constexpr std::uint32_t kMinSamplesPerCell = 32;
// The routing passes work on fixed chunks of ids; each chunk counts its
// entries per cell (a chunk x cell table of at most kMaxCountWords words:
// larger chunks when there are many cells). The cells' contents do not
// depend on the chunks (each cell is sorted by min x, then id, afterwards).
constexpr std::uint32_t kRouteChunk = 1u << 14;
constexpr std::size_t kMaxCountWords = std::size_t{1} << 20;
// cell_of: the object is in several cells (its descent forked).
constexpr std::uint32_t kSeveralCells = 0xFFFFFFFFu;
// In a chunk's list of the cells of its objects in several cells: marks
// an object's last cell.
constexpr std::uint32_t kLastCell = 0x80000000u;
// Cells up to this size are ordered with std::sort (a radix sort's
// histograms cost more there).
constexpr std::uint32_t kComparisonSortUpTo = 48;
// A thread's sort scratch is released after a cell larger than this.
constexpr std::size_t kKeepSortScratch = std::size_t{1} << 16;

// Calls visit(leaf node) for every leaf the box b (min x y z, max x y z)
// reaches from `start`, left to right, by the routing rule (left when
// min < split, right when max >= split). Returns the first node where the
// descent forked (kNoHome: the box reached one leaf). With kMargin, lowers
// `margin` to the smallest distance from a face of the box to a plane it was
// tested against.
template <bool kMargin, class Visit>
std::uint32_t descend(const KdTreeNode* nodes, const float* b, std::uint32_t start, float& margin, Visit&& visit) {
  // The stack holds at most one right child per level of the current path.
  std::array<std::uint32_t, KdPartition::kMaxDepth + 1> stack;
  std::uint32_t top = 0, fork = kNoHome, node = start;
  float m = margin;
  while (true) {
    while (nodes[node].axis >= 0) {
      const KdTreeNode& nd = nodes[node];
      const float lo = b[nd.axis], hi = b[3 + nd.axis];
      const bool left = lo < nd.split, right = hi >= nd.split;
      if constexpr (kMargin) m = std::min(m, std::min(std::abs(lo - nd.split), std::abs(hi - nd.split)));
      if (left && right) {
        if (fork == kNoHome) fork = node;
        stack[top++] = nd.child + 1;
      }
      node = nd.child + (left ? 0u : 1u);
    }
    visit(node);
    if (top == 0) break;
    node = stack[--top];
  }
  margin = m;
  return fork;
}

constexpr std::uint32_t kAxisShift = 30;
constexpr std::uint32_t kChildMask = (1u << kAxisShift) - 1;
static_assert(kMaxNodes <= kChildMask + 1);
// Objects stepped down the tree together (independent chains of loads: the
// latency of one level hides behind the others').
constexpr std::uint32_t kLockstep = 8;

// The sample: from each block of `rate` ids one object, at a pseudo-random
// position in the block (a fixed stride could alias with a pattern in the
// ids, e.g. every 16th object a huge one).
std::uint32_t sample_id(std::uint32_t block, std::uint32_t rate) {
  std::uint32_t h = block * 0x9E3779B1u;
  h ^= h >> 15;
  h *= 0x85EBCA77u;
  h ^= h >> 13;
  return block * rate + h % rate;
}

// Orders one cell's entries (in id order) by min x, ties by id.
void sort_cell(CellEntry* e, std::uint32_t n, std::vector<std::uint64_t>& keys, std::vector<CellEntry>& tmp) {
  if (n < 2) return;
  keys.resize(2 * std::size_t{n});
  std::uint64_t* k = keys.data();
  bool sorted = true;
  for (std::uint32_t i = 0; i < n; ++i) {
    k[i] = (std::uint64_t{float_order_key(e[i].min[0])} << 32) | i;
    sorted &= i == 0 || k[i - 1] < k[i];
  }
  if (sorted) return;
  if (n <= kComparisonSortUpTo) {
    std::sort(k, k + n);
  } else {
    k = radix_sort_keyed_indices(k, k + n, n);
  }
  tmp.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) tmp[i] = e[static_cast<std::uint32_t>(k[i])];
  std::memcpy(e, tmp.data(), std::size_t{n} * sizeof(CellEntry));
  // An over-full cell (identical boxes) does not keep its scratch for good.
  if (tmp.capacity() > kKeepSortScratch) {
    tmp = {};
    keys = {};
  }
}

}  // namespace

std::uint32_t sample_rate(std::size_t n, const SplitRule& rule) {
  if (n < kSampledBuildMinObjects || (rule.cell_cost && *rule.cell_cost)) return 1;
  const std::uint32_t rate = std::min(kMaxSampleRate, rule.cell_limit / kMinSamplesPerCell);
  return rate >= 2 ? rate : 1;
}

void build_tree_sampled(const BoxArray& boxes, const SplitRule& rule, std::uint32_t rate, SampledBuildBuffers& buffers,
                        RawBuffer<CellEntry>& scratch, std::vector<KdTreeNode>& nodes, RawBuffer<CellEntry>& entries,
                        std::uint32_t* home, StoredBox* prev, float* margin) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const float* const src[6] = {boxes.min(0), boxes.min(1), boxes.min(2), boxes.max(0), boxes.max(1), boxes.max(2)};

  // 1. The planes: a tree over the sample, down to the limit over the rate.
  const std::uint32_t samples = n / rate;
  RawBuffer<CellEntry>& sample = buffers.sample;
  sample.resize(samples);
  for (std::uint32_t j = 0; j < samples; ++j) {
    const std::uint32_t id = sample_id(j, rate);
    sample[j] = {{src[0][id], src[1][id], src[2][id]}, {src[3][id], src[4][id], src[5][id]}, id, 0};
  }
  const SplitRule sample_rule{rule.cell_limit / rate, rule.x_split_weight, nullptr};
  buffers.sample_tree.build(sample.data(), samples, 0, sample_rule, true, buffers.sample_scratch);
  nodes = buffers.sample_tree.nodes;  // local indices: the root is node 0, as the partition's
  const KdTreeNode* tree = nodes.data();

  // Cells in depth-first order, left before right (the partition's numbering).
  // depth: of the deepest leaf, the count pass's steps.
  std::vector<std::uint32_t> leaf_node;
  std::uint32_t depth = 0;
  {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> stack{{0, 0}};  // node, depth
    while (!stack.empty()) {
      const auto [x, d] = stack.back();
      stack.pop_back();
      if (nodes[x].axis < 0) {
        nodes[x].leaf = static_cast<std::uint32_t>(leaf_node.size());
        leaf_node.push_back(x);
        depth = std::max(depth, d);
      } else {
        stack.push_back({nodes[x].child + 1, d + 1});
        stack.push_back({nodes[x].child, d + 1});
      }
    }
  }
  const auto cells = static_cast<std::uint32_t>(leaf_node.size());

  // 2. Count pass, in id order: every object's descent from the root, its
  // entries counted per (chunk, cell), its home, margin and (homed at an
  // inner node) box recorded, and its one cell noted (or that it has several).
  std::uint32_t chunk = kRouteChunk;
  if (std::size_t{(n + chunk - 1) / chunk} * cells > kMaxCountWords) {
    const std::size_t most = std::max<std::size_t>(1, kMaxCountWords / cells);
    chunk = static_cast<std::uint32_t>((n + most - 1) / most);
  }
  const std::uint32_t chunks = (n + chunk - 1) / chunk;
  buffers.forked_cells.resize(chunks);
  buffers.counts.resize(std::size_t{chunks} * cells);
  std::uint32_t* const counts = buffers.counts.data();
  static_assert(sizeof(CellEntry) % sizeof(std::uint32_t) == 0);
  scratch.resize((std::size_t{n} * sizeof(std::uint32_t) + sizeof(CellEntry) - 1) / sizeof(CellEntry));
  auto* const cell_of = reinterpret_cast<std::uint32_t*>(scratch.data());
  std::vector<RouteNode>& route = buffers.route;
  route.resize(nodes.size());
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const KdTreeNode& nd = nodes[k];
    route[k] = nd.axis < 0 ? RouteNode{std::numeric_limits<float>::infinity(), static_cast<std::uint32_t>(k)}
                           : RouteNode{nd.split, nd.child | static_cast<std::uint32_t>(nd.axis) << kAxisShift};
  }
  const RouteNode* const walk = route.data();
  tbb::parallel_for(std::uint32_t{0}, chunks, [&, tree, walk, counts, cell_of](std::uint32_t c) {
    std::uint32_t* const count = counts + std::size_t{c} * cells;
    std::fill(count, count + cells, 0u);
    const std::uint32_t begin = c * chunk, end = std::min(n, (c + 1) * chunk);
    std::vector<std::uint32_t>& forked = buffers.forked.local();
    forked.clear();
    std::vector<std::uint32_t>& forked_cells = buffers.forked_cells[c];
    forked_cells.clear();
    // Groups of kLockstep objects step down together, each level a load of
    // its node, two compares and the next node; an object whose descent
    // forks goes on down its left side and is only flagged: it is routed
    // fully afterwards (home, margin, every cell), one object at a time.
    for (std::uint32_t g = begin; g < end; g += kLockstep) {
      const std::uint32_t lanes = std::min(kLockstep, end - g);
      float b[kLockstep][6];
      std::uint32_t node[kLockstep];
      bool several[kLockstep];
      for (std::uint32_t l = 0; l < kLockstep; ++l) {
        const std::uint32_t i = l < lanes ? g + l : g;  // a short group repeats its first object
        for (int a = 0; a < 6; ++a) b[l][a] = src[a][i];
        node[l] = 0;
        several[l] = false;
      }
      for (std::uint32_t level = 0; level < depth; ++level) {
        for (std::uint32_t l = 0; l < kLockstep; ++l) {
          const RouteNode nd = walk[node[l]];
          const std::uint32_t axis = nd.child_axis >> kAxisShift;
          const bool left = b[l][axis] < nd.split;
          several[l] |= left & (b[l][3 + axis] >= nd.split);
          node[l] = (nd.child_axis & kChildMask) + !left;
        }
      }
      for (std::uint32_t l = 0; l < lanes; ++l) {
        const std::uint32_t i = g + l;
        if (!several[l]) {
          home[i] = node[l];
          margin[i] = 0;  // not read for an object in one cell
          cell_of[i] = tree[node[l]].leaf;
          ++count[cell_of[i]];
        } else {
          cell_of[i] = kSeveralCells;
          forked.push_back(i);
        }
      }
    }
    // The margin needs only the planes at and below the home: find_crossings
    // tests the box against the home's region itself. Taken from the root
    // here (a smaller margin: the same decisions or more descents, never
    // fewer).
    for (const std::uint32_t i : forked) {
      const float b[6] = {src[0][i], src[1][i], src[2][i], src[3][i], src[4][i], src[5][i]};
      float m = std::numeric_limits<float>::infinity();
      home[i] = descend<true>(tree, b, 0, m, [&](std::uint32_t leaf) {
        ++count[tree[leaf].leaf];
        forked_cells.push_back(tree[leaf].leaf);
      });
      forked_cells.back() |= kLastCell;
      margin[i] = m;
      prev[i] = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
    }
  });

  // 3. Every cell's place (cells in order, within a cell chunk after chunk),
  // and each chunk's cursor per cell.
  std::size_t total = 0;
  for (std::uint32_t cell = 0; cell < cells; ++cell) {
    KdTreeNode& leaf = nodes[leaf_node[cell]];
    const std::size_t first = total;
    for (std::uint32_t c = 0; c < chunks; ++c) {
      std::uint32_t& k = counts[std::size_t{c} * cells + cell];
      const std::uint32_t count = k;
      k = static_cast<std::uint32_t>(total);
      total += count;
    }
    if (total > std::numeric_limits<std::uint32_t>::max() / 2)
      throw CapacityExceeded("k-d partition: more than 2^31 cell entries (" + std::to_string(total) + ")");
    leaf.first = static_cast<std::uint32_t>(first);
    leaf.size = static_cast<std::uint32_t>(total - first);
  }
  entries.clear();  // nothing kept: never copied if it must grow
  entries.resize(total);

  // 4. Scatter pass, in id order: each object's entry into its cells (those
  // of objects in several cells as the count pass listed them).
  CellEntry* const out = entries.data();
  tbb::parallel_for(std::uint32_t{0}, chunks, [&, counts, cell_of, out](std::uint32_t c) {
    std::uint32_t* const cursor = counts + std::size_t{c} * cells;
    const std::uint32_t* listed = buffers.forked_cells[c].data();
    const std::uint32_t end = std::min(n, (c + 1) * chunk);
    for (std::uint32_t i = c * chunk; i < end; ++i) {
      const CellEntry e = {{src[0][i], src[1][i], src[2][i]}, {src[3][i], src[4][i], src[5][i]}, i, 0};
      const std::uint32_t cell = cell_of[i];
      if (cell != kSeveralCells) {
        out[cursor[cell]++] = e;
        continue;
      }
      std::uint32_t w;
      do {
        w = *listed++;
        out[cursor[w & ~kLastCell]++] = e;
      } while (!(w & kLastCell));
    }
  });
  for (auto& list : buffers.forked_cells)
    if (list.capacity() > 2 * list.size() + 4096) list.shrink_to_fit();

  // 5. Each cell (in id order now) into min-x order, ties by id, in the cache.
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, cells, 8), [&, out](const auto& r) {
    std::vector<std::uint64_t>& keys = buffers.sort_keys.local();
    std::vector<CellEntry>& tmp = buffers.sort_entries.local();
    for (std::uint32_t cell = r.begin(); cell != r.end(); ++cell) {
      const KdTreeNode& leaf = nodes[leaf_node[cell]];
      sort_cell(out + leaf.first, leaf.size, keys, tmp);
    }
  });
}

}  // namespace hbp::kd
