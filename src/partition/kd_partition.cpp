#include "hbp/kd_partition.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "hbp/error.hpp"

namespace hbp {

namespace {

constexpr std::uint32_t kMaxDepth = 64;
// Routing and scattering work on a fixed number of chunks, so the result
// never depends on the thread count.
constexpr std::uint32_t kRouteChunks = 64;

// Order-preserving map from float to unsigned (negative values flipped).
inline std::uint32_t float_key(float f) {
  const auto u = std::bit_cast<std::uint32_t>(f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

}  // namespace

KdPartition::KdPartition(std::uint32_t cell_limit) : cell_limit_(cell_limit) {
  if (cell_limit < 2) throw InvalidInput("cell limit must be >= 2 (got " + std::to_string(cell_limit) + ")");
}

void KdPartition::reset() { nodes_.clear(); }

void KdPartition::sort_by_min_x(const BoxArray& boxes) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  keys_.resize(n);
  keys_tmp_.resize(n);
  ids_.resize(n);
  ids_tmp_.resize(n);
  const float* minx = boxes.min(0);
  for (std::uint32_t i = 0; i < n; ++i) {
    keys_[i] = float_key(minx[i]);
    ids_[i] = i;
  }
  // LSD radix sort, 11-bit digits, stable: equal keys keep id order.
  std::uint32_t* k_src = keys_.data();
  std::uint32_t* k_dst = keys_tmp_.data();
  std::uint32_t* i_src = ids_.data();
  std::uint32_t* i_dst = ids_tmp_.data();
  std::uint32_t count[2048];
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = pass * 11;
    std::memset(count, 0, sizeof(count));
    for (std::uint32_t i = 0; i < n; ++i) ++count[(k_src[i] >> shift) & 2047];
    std::uint32_t sum = 0;
    for (auto& c : count) {
      const std::uint32_t t = c;
      c = sum;
      sum += t;
    }
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t d = count[(k_src[i] >> shift) & 2047]++;
      k_dst[d] = k_src[i];
      i_dst[d] = i_src[i];
    }
    std::swap(k_src, k_dst);
    std::swap(i_src, i_dst);
  }
  if (i_src != ids_.data()) std::memcpy(ids_.data(), i_src, n * sizeof(std::uint32_t));

  sorted_.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, n, 8192), [&](const auto& r) {
    for (int l = 0; l < 3; ++l) {
      const float* src_min = boxes.min(l);
      const float* src_max = boxes.max(l);
      float* dst_min = sorted_.min(l);
      float* dst_max = sorted_.max(l);
      for (std::uint32_t i = r.begin(); i != r.end(); ++i) {
        dst_min[i] = src_min[ids_[i]];
        dst_max[i] = src_max[ids_[i]];
      }
    }
  });
}

void KdPartition::build(std::vector<std::uint32_t>& positions) {
  nodes_.clear();
  nodes_.push_back(Node{});
  build_node(0, positions, 0);
}

void KdPartition::build_node(std::uint32_t node, std::vector<std::uint32_t>& positions, std::uint32_t depth) {
  const auto count = static_cast<std::uint32_t>(positions.size());
  nodes_[node].axis = -1;
  nodes_[node].size = count;
  if (count <= cell_limit_ || depth >= kMaxDepth) return;

  // Axes ordered by the spread of box centres, widest first.
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<float>::infinity();
    hi[a] = -std::numeric_limits<float>::infinity();
    const float* mn = sorted_.min(a);
    const float* mx = sorted_.max(a);
    for (std::uint32_t p : positions) {
      const float c = 0.5f * mn[p] + 0.5f * mx[p];
      lo[a] = std::min(lo[a], c);
      hi[a] = std::max(hi[a], c);
    }
  }
  int axes[3] = {0, 1, 2};
  std::stable_sort(axes, axes + 3, [&](int x, int y) { return hi[x] - lo[x] > hi[y] - lo[y]; });

  std::vector<std::uint32_t> left, right;
  for (int a : axes) {
    if (!(hi[a] > lo[a])) continue;
    const float* mn = sorted_.min(a);
    const float* mx = sorted_.max(a);
    scratch_.resize(count);
    for (std::uint32_t i = 0; i < count; ++i) scratch_[i] = 0.5f * mn[positions[i]] + 0.5f * mx[positions[i]];
    auto mid = scratch_.begin() + count / 2;
    std::nth_element(scratch_.begin(), mid, scratch_.end());
    float split = *mid;
    if (!(split > lo[a])) split = std::nextafter(lo[a], hi[a]);  // keep the left side non-empty
    left.clear();
    right.clear();
    for (std::uint32_t p : positions) {
      if (mn[p] < split) left.push_back(p);
      if (mx[p] >= split) right.push_back(p);
    }
    if (left.size() < count && right.size() < count) {
      const auto child = static_cast<std::uint32_t>(nodes_.size());
      nodes_[node].axis = a;
      nodes_[node].split = split;
      nodes_[node].child = child;
      nodes_.push_back(Node{});
      nodes_.push_back(Node{});
      std::vector<std::uint32_t>().swap(positions);  // release before recursing
      build_node(child, left, depth + 1);
      build_node(child + 1, right, depth + 1);
      return;
    }
  }
  // No axis shrinks both halves: an over-full leaf, processed in tiles.
}

void KdPartition::number_leaves() {
  leaf_nodes_.clear();
  regions_.clear();
  const float inf = std::numeric_limits<float>::infinity();
  struct Item {
    std::uint32_t node;
    CellRegion region;
    std::uint32_t depth;
  };
  std::vector<Item> stack;
  stack.push_back({0, {{-inf, -inf, -inf}, {inf, inf, inf}}, 0});
  stats_.depth = 0;
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    Node& nd = nodes_[it.node];
    stats_.depth = std::max(stats_.depth, it.depth);
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
  const auto n = static_cast<std::uint32_t>(sorted_.size());
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  chunk_routes_.resize(kRouteChunks);
  std::vector<std::uint32_t> counts(static_cast<std::size_t>(kRouteChunks) * cells, 0);
  const Node* nodes = nodes_.data();
  const float* mn[3] = {sorted_.min(0), sorted_.min(1), sorted_.min(2)};
  const float* mx[3] = {sorted_.max(0), sorted_.max(1), sorted_.max(2)};
  tbb::parallel_for(std::uint32_t{0}, kRouteChunks, [&](std::uint32_t c) {
    const std::uint32_t begin = static_cast<std::uint32_t>(std::uint64_t{n} * c / kRouteChunks);
    const std::uint32_t end = static_cast<std::uint32_t>(std::uint64_t{n} * (c + 1) / kRouteChunks);
    auto& out = chunk_routes_[c];
    out.clear();
    std::uint32_t* cnt = counts.data() + static_cast<std::size_t>(c) * cells;
    std::uint32_t stack[kMaxDepth + 2];
    for (std::uint32_t p = begin; p < end; ++p) {
      std::uint32_t top = 0;
      stack[top++] = 0;
      while (top) {
        const Node& nd = nodes[stack[--top]];
        if (nd.axis < 0) {
          out.push_back((std::uint64_t{nd.leaf} << 32) | p);
          ++cnt[nd.leaf];
          continue;
        }
        // Right pushed first so the left subtree is visited first.
        if (mx[nd.axis][p] >= nd.split) stack[top++] = nd.child + 1;
        if (mn[nd.axis][p] < nd.split) stack[top++] = nd.child;
      }
    }
  });
  offsets_.assign(cells + 1, 0);
  // Offsets per (cell, chunk): chunks in order inside each cell keeps every
  // cell sorted by position, i.e. by min x.
  std::uint64_t total = 0;
  for (std::uint32_t cell = 0; cell < cells; ++cell) {
    offsets_[cell] = static_cast<std::uint32_t>(total);
    for (std::uint32_t c = 0; c < kRouteChunks; ++c) {
      std::uint32_t& v = counts[static_cast<std::size_t>(c) * cells + cell];
      const std::uint32_t t = v;
      v = static_cast<std::uint32_t>(total);
      total += t;
    }
  }
  if (total > std::numeric_limits<std::uint32_t>::max())
    throw CapacityExceeded("k-d partition: more than 2^32 cell entries (" + std::to_string(total) + ")");
  offsets_[cells] = static_cast<std::uint32_t>(total);
  entries_.resize(total);
  tbb::parallel_for(std::uint32_t{0}, kRouteChunks, [&](std::uint32_t c) {
    std::uint32_t* cursor = counts.data() + static_cast<std::size_t>(c) * cells;
    for (std::uint64_t e : chunk_routes_[c]) entries_[cursor[e >> 32]++] = static_cast<std::uint32_t>(e);
  });
  for (std::uint32_t cell = 0; cell < cells; ++cell)
    nodes_[leaf_nodes_[cell]].size = offsets_[cell + 1] - offsets_[cell];
}

void KdPartition::split_oversized() {
  stats_.splits = 0;
  bool changed = false;
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  std::vector<std::uint32_t> positions;
  for (std::uint32_t cell = 0; cell < cells; ++cell) {
    if (offsets_[cell + 1] - offsets_[cell] <= cell_limit_) continue;
    const std::uint32_t node = leaf_nodes_[cell];
    positions.assign(entries_.begin() + offsets_[cell], entries_.begin() + offsets_[cell + 1]);
    build_node(node, positions, 0);
    if (nodes_[node].axis >= 0) {
      ++stats_.splits;
      changed = true;
    }
  }
  if (changed) {
    number_leaves();
    route_all();
  }
}

void KdPartition::merge_sparse() {
  // Sibling leaves that together hold at most a quarter of the limit become
  // one leaf (their old nodes are left unused until the next rebuild).
  stats_.merges = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    Node& nd = nodes_[i];
    if (nd.axis < 0) continue;
    const Node& l = nodes_[nd.child];
    const Node& r = nodes_[nd.child + 1];
    if (l.axis < 0 && r.axis < 0 && l.size + r.size <= cell_limit_ / 4) {
      nd.size = l.size + r.size;
      nd.axis = -1;
      ++stats_.merges;
    }
  }
}

void KdPartition::compute_stats() {
  const auto cells = static_cast<std::uint32_t>(leaf_nodes_.size());
  stats_.cells = cells;
  stats_.entries = entries_.size();
  stats_.oversized_cells = 0;
  std::vector<std::uint32_t> sizes(cells);
  for (std::uint32_t c = 0; c < cells; ++c) {
    sizes[c] = offsets_[c + 1] - offsets_[c];
    if (sizes[c] > cell_limit_) ++stats_.oversized_cells;
  }
  if (cells) {
    std::sort(sizes.begin(), sizes.end());
    stats_.min_cell = sizes.front();
    stats_.max_cell = sizes.back();
    stats_.median_cell = sizes[cells / 2];
  }
  stats_.duplication = sorted_.size() ? static_cast<double>(entries_.size()) / static_cast<double>(sorted_.size()) : 1.0;
}

void KdPartition::update(const BoxArray& boxes) {
  if (boxes.size() >= std::numeric_limits<std::uint32_t>::max())
    throw CapacityExceeded("k-d partition: at most 2^32 - 1 objects per frame");
  sort_by_min_x(boxes);
  stats_.rebuilt = false;
  stats_.merges = 0;
  if (!nodes_.empty()) {
    merge_sparse();
    number_leaves();
    route_all();
    split_oversized();
    ++frames_since_rebuild_;
    // Quality check against the tree as it was right after the last rebuild.
    const double dup = sorted_.size() ? static_cast<double>(entries_.size()) / static_cast<double>(sorted_.size()) : 1.0;
    std::uint32_t used = 0;
    for (const Node& nd : nodes_) used += nd.axis >= 0 ? 2 : 0;
    const bool degraded = dup > 1.2 * rebuild_duplication_ + 0.01 ||
                          leaf_nodes_.size() > 2 * std::size_t{rebuild_cells_} + 8 ||
                          nodes_.size() > 2 * (std::size_t{used} + 1);
    if (degraded) nodes_.clear();
  }
  if (nodes_.empty()) {
    std::vector<std::uint32_t> all(sorted_.size());
    for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
    build(all);
    number_leaves();
    route_all();
    stats_.rebuilt = true;
    frames_since_rebuild_ = 0;
    rebuild_duplication_ = sorted_.size() ? static_cast<double>(entries_.size()) / static_cast<double>(sorted_.size()) : 1.0;
    rebuild_cells_ = static_cast<std::uint32_t>(leaf_nodes_.size());
  }
  compute_stats();
}

}  // namespace hbp
