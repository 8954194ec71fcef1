#include "hbp/kd_partition.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <utility>
#include <limits>
#include <string>

#include "hbp/error.hpp"

namespace hbp {

namespace {

constexpr std::uint32_t kMaxDepth = 64;
// Routing and scattering work on a fixed number of chunks of object ids, so
// the result never depends on the thread count.
constexpr std::uint32_t kRouteChunks = 64;

}  // namespace

KdPartition::KdPartition(std::uint32_t cell_limit, float x_split_weight, CellCost cell_cost)
    : cell_limit_(cell_limit), x_split_weight_(x_split_weight), cell_cost_(std::move(cell_cost)) {
  if (cell_limit < 2) throw InvalidInput("cell limit must be >= 2 (got " + std::to_string(cell_limit) + ")");
}

void KdPartition::reset() { nodes_.clear(); }

void KdPartition::build(std::vector<std::uint32_t>& ids) {
  nodes_.clear();
  nodes_.push_back(Node{});
  build_node(0, ids, 0);
}

void KdPartition::build_node(std::uint32_t node, std::vector<std::uint32_t>& ids, std::uint32_t depth) {
  const auto count = static_cast<std::uint32_t>(ids.size());
  nodes_[node].axis = -1;
  nodes_[node].size = count;
  const bool over_limit = count > cell_limit_;
  if ((!over_limit && !cell_cost_) || count < 4 || depth >= kMaxDepth) return;
  const BoxArray& boxes = *boxes_;

  // Axes ordered by the spread of box centres, widest first.
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<float>::infinity();
    hi[a] = -std::numeric_limits<float>::infinity();
    const float* mn = boxes.min(a);
    const float* mx = boxes.max(a);
    for (std::uint32_t id : ids) {
      const float c = 0.5f * mn[id] + 0.5f * mx[id];
      lo[a] = std::min(lo[a], c);
      hi[a] = std::max(hi[a], c);
    }
  }
  int axes[3] = {0, 1, 2};
  const float xw = std::getenv("XW") ? std::atof(std::getenv("XW")) : 1.0f;
  auto spread = [&](int a) { return (hi[a] - lo[a]) * (a == 0 ? xw : 1.0f); };
  std::stable_sort(axes, axes + 3, [&](int x, int y) { return spread(x) > spread(y); });

  std::vector<std::uint32_t> left, right;
  for (int a : axes) {
    if (!(hi[a] > lo[a])) continue;
    const float* mn = boxes.min(a);
    const float* mx = boxes.max(a);
    scratch_.resize(count);
    for (std::uint32_t i = 0; i < count; ++i) scratch_[i] = 0.5f * mn[ids[i]] + 0.5f * mx[ids[i]];
    auto mid = scratch_.begin() + count / 2;
    std::nth_element(scratch_.begin(), mid, scratch_.end());
    float split = *mid;
    if (!(split > lo[a])) split = std::nextafter(lo[a], hi[a]);  // keep the left side non-empty
    left.clear();
    right.clear();
    for (std::uint32_t id : ids) {
      if (mn[id] < split) left.push_back(id);
      if (mx[id] >= split) right.push_back(id);
    }
    bool accept = left.size() < count && right.size() < count;
    if (accept && !over_limit) {
      // Under the limit: split only if the engine's summed cost drops.
      const double children = cell_cost_(static_cast<std::uint32_t>(left.size())) +
                              cell_cost_(static_cast<std::uint32_t>(right.size()));
      accept = children < 0.95 * cell_cost_(count);
    }
    if (accept) {
      const auto child = static_cast<std::uint32_t>(nodes_.size());
      nodes_[node].axis = a;
      nodes_[node].split = split;
      nodes_[node].child = child;
      nodes_.push_back(Node{});
      nodes_.push_back(Node{});
      std::vector<std::uint32_t>().swap(ids);  // release before recursing
      build_node(child, left, depth + 1);
      build_node(child + 1, right, depth + 1);
      return;
    }
  }
  // No axis shrinks both halves: an over-full leaf, processed in tiles.
}

void KdPartition::number_leaves() {
  ++epoch_;
  leaf_nodes_.clear();
  regions_.clear();
  node_regions_.resize(nodes_.size());
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
    Node& nd = nodes_[it.node];
    nd.epoch = epoch_;
    stats_.depth = std::max(stats_.depth, it.depth);
    node_regions_[it.node] = it.region;
    if (nd.axis < 0) {
      nd.leaf = static_cast<std::uint32_t>(leaf_nodes_.size());
      leaf_nodes_.push_back(it.node);
      regions_.push_back(it.region);
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
}

void KdPartition::route_all() {
  const BoxArray& boxes = *boxes_;
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  chunk_routes_.resize(kRouteChunks);
  chunk_counts_.assign(static_cast<std::size_t>(kRouteChunks) * cells, 0);
  const Node* nodes = nodes_.data();
  const CellRegion* node_regions = node_regions_.data();
  const std::uint32_t epoch = epoch_;
  tbb::parallel_for(std::uint32_t{0}, kRouteChunks, [&](std::uint32_t c) {
    const auto begin = static_cast<std::uint32_t>(std::uint64_t{n} * c / kRouteChunks);
    const auto end = static_cast<std::uint32_t>(std::uint64_t{n} * (c + 1) / kRouteChunks);
    auto& out = chunk_routes_[c];
    out.clear();
    std::uint32_t* cnt = chunk_counts_.data() + static_cast<std::size_t>(c) * cells;
    std::uint32_t stack[kMaxDepth + 2];
    for (std::uint32_t id = begin; id < end; ++id) {
      const float b[6] = {boxes.min(0)[id], boxes.min(1)[id], boxes.min(2)[id],
                          boxes.max(0)[id], boxes.max(1)[id], boxes.max(2)[id]};
      // Coherence: home_ holds the deepest node whose subtree held all of the
      // object's cells last frame (its leaf, when it was in one cell). If the
      // box is still strictly inside that node's region, a descent from the
      // root would enter no other subtree: start there.
      std::uint32_t node = 0;
      const std::uint32_t home = home_[id];
      if (home != kNoHome && nodes[home].epoch == epoch) {
        const CellRegion& r = node_regions[home];
        if (b[0] >= r.lo[0] && b[3] < r.hi[0] && b[1] >= r.lo[1] && b[4] < r.hi[1] && b[2] >= r.lo[2] &&
            b[5] < r.hi[2])
          node = home;
      }
      std::uint32_t top = 0, deepest = kNoHome;
      while (true) {
        // Descend: straddling the plane is the rare case, so only it
        // branches; the common one-sided step is a select.
        while (nodes[node].axis >= 0) {
          const Node& nd = nodes[node];
          const bool left = b[nd.axis] < nd.split;
          const bool right = b[3 + nd.axis] >= nd.split;
          if (left && right) {
            if (deepest == kNoHome) deepest = node;  // first fork: the subtree root
            stack[top++] = nd.child + 1;
          }
          node = nd.child + (left ? 0u : 1u);
        }
        out.push_back((std::uint64_t{nodes[node].leaf} << 32) | id);
        ++cnt[nodes[node].leaf];
        if (deepest == kNoHome) deepest = node;  // one cell only: its leaf
        if (top == 0) break;
        node = stack[--top];
      }
      home_[id] = deepest;
    }
  });
  // Positions per (cell, chunk): chunks in order inside each cell keep every
  // cell's ids increasing.
  std::uint64_t total = 0;
  for (std::uint32_t cell = 0; cell < cells; ++cell) {
    Node& leaf = nodes_[leaf_nodes_[cell]];
    leaf.first = static_cast<std::uint32_t>(std::min<std::uint64_t>(total, 0xFFFFFFFFu));
    for (std::uint32_t c = 0; c < kRouteChunks; ++c) {
      std::uint32_t& v = chunk_counts_[static_cast<std::size_t>(c) * cells + cell];
      const std::uint32_t t = v;
      v = static_cast<std::uint32_t>(total);
      total += t;
    }
    leaf.size = static_cast<std::uint32_t>(std::min<std::uint64_t>(total - leaf.first, 0xFFFFFFFFu));
  }
  if (total > std::numeric_limits<std::uint32_t>::max() / 2)
    throw CapacityExceeded("k-d partition: more than 2^31 cell entries (" + std::to_string(total) + ")");
  entries_.resize(total);
  tbb::parallel_for(std::uint32_t{0}, kRouteChunks, [&](std::uint32_t c) {
    std::uint32_t* cursor = chunk_counts_.data() + static_cast<std::size_t>(c) * cells;
    const float* src[6] = {boxes.min(0), boxes.min(1), boxes.min(2), boxes.max(0), boxes.max(1), boxes.max(2)};
    CellEntry* dst = entries_.data();
    for (std::uint64_t e : chunk_routes_[c]) {
      const auto id = static_cast<std::uint32_t>(e);
      dst[cursor[e >> 32]++] = {{src[0][id], src[1][id], src[2][id]}, {src[3][id], src[4][id], src[5][id]}, id, 0};
    }
  });
}

bool KdPartition::split_oversized() {
  stats_.splits = 0;
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  std::vector<std::uint32_t> ids;
  std::vector<CellEntry> moved;
  for (std::uint32_t cell = 0; cell < cells; ++cell) {
    const std::uint32_t node = leaf_nodes_[cell];
    if (nodes_[node].size <= cell_limit_) continue;
    moved.assign(entries_.begin() + nodes_[node].first, entries_.begin() + nodes_[node].first + nodes_[node].size);
    ids.clear();
    for (const CellEntry& e : moved) ids.push_back(e.id);
    build_node(node, ids, 0);
    if (nodes_[node].axis < 0) continue;  // could not split: entries stay in place
    ++stats_.splits;
    route_subtree(node, moved);
  }
  return stats_.splits > 0;
}

void KdPartition::route_subtree(std::uint32_t root, const std::vector<CellEntry>& moved) {
  // Only the split leaf's entries move: through its new subtree, appended to
  // entries_ leaf by leaf (in id order), the other cells untouched.
  std::vector<std::vector<CellEntry>> lists;
  std::vector<std::uint32_t> leaves;
  std::vector<std::uint32_t> stack{root};
  while (!stack.empty()) {  // leaves of the subtree, left to right
    const std::uint32_t node = stack.back();
    stack.pop_back();
    if (nodes_[node].axis < 0) {
      nodes_[node].leaf = static_cast<std::uint32_t>(leaves.size());
      leaves.push_back(node);
      continue;
    }
    stack.push_back(nodes_[node].child + 1);
    stack.push_back(nodes_[node].child);
  }
  lists.resize(leaves.size());
  for (const CellEntry& e : moved) {
    const float b[6] = {e.min[0], e.min[1], e.min[2], e.max[0], e.max[1], e.max[2]};
    stack.assign(1, root);
    while (!stack.empty()) {
      const Node& nd = nodes_[stack.back()];
      stack.pop_back();
      if (nd.axis < 0) {
        lists[nd.leaf].push_back(e);
        continue;
      }
      if (b[3 + nd.axis] >= nd.split) stack.push_back(nd.child + 1);
      if (b[nd.axis] < nd.split) stack.push_back(nd.child);
    }
  }
  for (std::size_t l = 0; l < leaves.size(); ++l) {
    Node& leaf = nodes_[leaves[l]];
    leaf.first = static_cast<std::uint32_t>(entries_.size());
    leaf.size = static_cast<std::uint32_t>(lists[l].size());
    entries_.insert(entries_.end(), lists[l].begin(), lists[l].end());
  }
}

void KdPartition::merge_sparse() {
  // Sibling leaves that together held at most a quarter of the limit last
  // frame become one leaf (their nodes stay unused until the next rebuild).
  stats_.merges = 0;
  std::vector<std::uint32_t> stack{0};
  while (!stack.empty()) {
    Node& nd = nodes_[stack.back()];
    stack.pop_back();
    if (nd.axis < 0) continue;
    const Node& l = nodes_[nd.child];
    const Node& r = nodes_[nd.child + 1];
    if (l.axis < 0 && r.axis < 0) {
      const bool merge = cell_cost_ ? (l.size + r.size <= cell_limit_ &&
                                       cell_cost_(l.size + r.size) <= cell_cost_(l.size) + cell_cost_(r.size))
                                    : l.size + r.size <= cell_limit_ / 4;
      if (merge) {
        nd.size = l.size + r.size;
        nd.axis = -1;
        ++stats_.merges;
      }
      continue;
    }
    stack.push_back(nd.child);
    stack.push_back(nd.child + 1);
  }
}

void KdPartition::compute_stats() {
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  stats_.cells = cells;
  stats_.oversized_cells = 0;
  std::vector<std::uint32_t> sizes(cells);
  std::uint64_t entries = 0;
  for (std::uint32_t c = 0; c < cells; ++c) {
    sizes[c] = cell_size(c);
    entries += sizes[c];
    if (sizes[c] > cell_limit_) ++stats_.oversized_cells;
  }
  stats_.entries = entries;
  if (cells) {
    std::sort(sizes.begin(), sizes.end());
    stats_.min_cell = sizes.front();
    stats_.max_cell = sizes.back();
    stats_.median_cell = sizes[cells / 2];
  }
  const auto n = static_cast<double>(boxes_->size());
  stats_.duplication = n > 0 ? static_cast<double>(entries) / n : 1.0;
}

void KdPartition::update(const BoxArray& boxes) {
  if (boxes.size() >= std::numeric_limits<std::uint32_t>::max())
    throw CapacityExceeded("k-d partition: at most 2^32 - 1 objects per frame");
  boxes_ = &boxes;
  if (home_.size() != boxes.size()) home_.assign(boxes.size(), kNoHome);
  stats_.rebuilt = false;
  stats_.merges = 0;
  stats_.splits = 0;
  if (!nodes_.empty()) {
    merge_sparse();
    number_leaves();
    route_all();
    if (split_oversized()) number_leaves();
    compute_stats();
    // Quality check against the tree as it was right after the last rebuild.
    std::size_t live = 1;
    for (const Node& nd : nodes_) live += (nd.axis >= 0 && nd.epoch == epoch_) ? 2 : 0;
    const bool degraded = stats_.duplication > 1.2 * rebuild_duplication_ + 0.01 ||
                          leaf_nodes_.size() > 2 * std::size_t{rebuild_cells_} + 8 || nodes_.size() > 2 * live + 64;
    if (degraded) nodes_.clear();
  }
  if (nodes_.empty()) {
    std::vector<std::uint32_t> all(boxes.size());
    for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
    build(all);
    number_leaves();
    route_all();
    compute_stats();
    stats_.rebuilt = true;
    rebuild_duplication_ = stats_.duplication;
    rebuild_cells_ = static_cast<std::uint32_t>(leaf_nodes_.size());
  }
}

}  // namespace hbp
