// SPDX-License-Identifier: MIT
#include "hierarchy/cell_bvh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "support/parallel_for.hpp"

namespace hbp::bvh {

namespace {

constexpr int kBins = 16;
constexpr std::uint32_t kNone = 0xFFFFFFFFu;
constexpr std::uint32_t kParallelBuild = 8192;   // items per subtree built as a task
constexpr std::uint32_t kParallelRefit = 32768;  // nodes per subtree refitted as a task
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Bounds {
  float lo[3] = {kInf, kInf, kInf};
  float hi[3] = {-kInf, -kInf, -kInf};
  void grow(const float* mn, const float* mx) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], mn[k]);
      hi[k] = std::max(hi[k], mx[k]);
    }
  }
  void grow_point(const float* p) { grow(p, p); }
  double area() const {
    if (!(hi[0] >= lo[0])) return 0;
    const double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
    return dx * dy + dy * dz + dz * dx;
  }
};

double node_area(const BvhNode& n) {
  const double dx = double(n.max[0]) - n.min[0], dy = double(n.max[1]) - n.min[1],
               dz = double(n.max[2]) - n.min[2];
  return dx * dy + dy * dz + dz * dx;
}

void set_union(BvhNode& out, const BvhNode& a, const BvhNode& b) {
  for (int k = 0; k < 3; ++k) {
    out.min[k] = std::min(a.min[k], b.min[k]);
    out.max[k] = std::max(a.max[k], b.max[k]);
  }
}

// Centroid (doubled: min + max) of an item.
inline float centre2(const CellEntry& e, int axis) { return e.min[axis] + e.max[axis]; }

void build_range(CellEntry* items, std::uint32_t count, BvhNode* nodes, std::uint32_t node) {
  BvhNode& n = nodes[node];
  Bounds box, cbox;
  for (std::uint32_t i = 0; i < count; ++i) {
    box.grow(items[i].min, items[i].max);
    const float c[3] = {centre2(items[i], 0), centre2(items[i], 1), centre2(items[i], 2)};
    cbox.grow_point(c);
  }
  for (int k = 0; k < 3; ++k) {
    n.min[k] = box.lo[k];
    n.max[k] = box.hi[k];
  }
  if (count == 1) {
    n.right = items[0].build_tag;  // the entry index travels in `build_tag` while building
    n.object = items[0].id;
    return;
  }

  // Binned SAH over the three axes.
  int best_axis = -1, best_split = 0;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    const float extent = cbox.hi[axis] - cbox.lo[axis];
    if (!(extent > 0)) continue;
    const float scale = kBins * (1 - 1e-6f) / extent;
    Bounds bins[kBins];
    std::uint32_t counts[kBins] = {};
    for (std::uint32_t i = 0; i < count; ++i) {
      int b = static_cast<int>((centre2(items[i], axis) - cbox.lo[axis]) * scale);
      b = std::clamp(b, 0, kBins - 1);
      ++counts[b];
      bins[b].grow(items[i].min, items[i].max);
    }
    double right_area[kBins];
    std::uint32_t right_count[kBins];
    Bounds acc;
    std::uint32_t cnt = 0;
    for (int b = kBins - 1; b > 0; --b) {
      acc.grow(bins[b].lo, bins[b].hi);
      cnt += counts[b];
      right_area[b] = acc.area();
      right_count[b] = cnt;
    }
    Bounds left;
    std::uint32_t left_count = 0;
    for (int b = 1; b < kBins; ++b) {
      left.grow(bins[b - 1].lo, bins[b - 1].hi);
      left_count += counts[b - 1];
      if (left_count == 0 || right_count[b] == 0) continue;
      const double cost = left.area() * left_count + right_area[b] * right_count[b];
      if (cost < best_cost) {
        best_cost = cost;
        best_axis = axis;
        best_split = b;
      }
    }
  }

  std::uint32_t mid = count / 2;
  if (best_axis >= 0) {
    const int axis = best_axis;
    const float scale = kBins * (1 - 1e-6f) / (cbox.hi[axis] - cbox.lo[axis]);
    CellEntry* split = std::partition(items, items + count, [&](const CellEntry& e) {
      const int b = std::clamp(static_cast<int>((centre2(e, axis) - cbox.lo[axis]) * scale), 0, kBins - 1);
      return b < best_split;
    });
    mid = static_cast<std::uint32_t>(split - items);
  }
  if (mid == 0 || mid == count) {
    // All centroids coincide (or binning could not separate them): halve by count.
    mid = count / 2;
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (cbox.hi[k] - cbox.lo[k] > cbox.hi[axis] - cbox.lo[axis]) axis = k;
    std::nth_element(items, items + mid, items + count,
                     [&](const CellEntry& a, const CellEntry& b) { return centre2(a, axis) < centre2(b, axis); });
  }

  const std::uint32_t left = node + 1, right = node + 2 * mid;
  n.right = right;
  n.object = BvhNode::kInternal;
  if (count >= kParallelBuild) {
    detail::parallel_invoke([&] { build_range(items, mid, nodes, left); },
                            [&] { build_range(items + mid, count - mid, nodes, right); });
  } else {
    build_range(items, mid, nodes, left);
    build_range(items + mid, count - mid, nodes, right);
  }
}

void build_items(std::vector<CellEntry>& items, std::vector<BvhNode>& nodes) {
  const auto count = static_cast<std::uint32_t>(items.size());
  if (count == 0) {
    nodes.clear();
    return;
  }
  nodes.resize(2 * static_cast<std::size_t>(count) - 1);
  build_range(items.data(), count, nodes.data(), 0);
}

template <class LeafBox>
double refit_serial(BvhNode* nodes, std::uint32_t begin, std::uint32_t end, const LeafBox& leaf_box) {
  double internal_area = 0;
  for (std::uint32_t i = end; i-- > begin;) {
    BvhNode& n = nodes[i];
    if (n.leaf()) {
      leaf_box(n);
    } else {
      set_union(n, nodes[i + 1], nodes[n.right]);
      internal_area += node_area(n);
    }
  }
  return internal_area;
}

// Refits the subtree occupying [begin, end); returns the sum of its internal areas.
template <class LeafBox>
double refit_parallel(BvhNode* nodes, std::uint32_t begin, std::uint32_t end, const LeafBox& leaf_box) {
  if (end - begin < kParallelRefit) return refit_serial(nodes, begin, end, leaf_box);
  BvhNode& n = nodes[begin];
  double a = 0, b = 0;
  detail::parallel_invoke([&] { a = refit_parallel(nodes, begin + 1, n.right, leaf_box); },
                          [&] { b = refit_parallel(nodes, n.right, end, leaf_box); });
  set_union(n, nodes[begin + 1], nodes[n.right]);
  return a + b + node_area(n);
}

float cost_of(double internal_area, const BvhNode& root, std::size_t nodes) {
  if (nodes < 3) return 0;
  const double root_area = node_area(root);
  return root_area > 0 ? static_cast<float>(internal_area / root_area) : 0.0f;
}

}  // namespace

void build(std::span<const CellEntry> entries, std::vector<BvhNode>& nodes, Scratch& scratch) {
  scratch.items.assign(entries.begin(), entries.end());
  for (std::uint32_t i = 0; i < scratch.items.size(); ++i) scratch.items[i].build_tag = i;
  build_items(scratch.items, nodes);
}

void build(const BoxArray& boxes, std::vector<BvhNode>& nodes, Scratch& scratch) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  scratch.items.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    CellEntry& e = scratch.items[i];
    for (int k = 0; k < 3; ++k) {
      e.min[k] = boxes.min(k)[i];
      e.max[k] = boxes.max(k)[i];
    }
    e.id = i;
    e.build_tag = i;
  }
  build_items(scratch.items, nodes);
}

float refit(std::span<const CellEntry> entries, std::span<BvhNode> nodes) {
  if (nodes.empty()) return 0;
  const double area = refit_serial(nodes.data(), 0, static_cast<std::uint32_t>(nodes.size()), [&](BvhNode& n) {
    const CellEntry& e = entries[n.right];
    for (int k = 0; k < 3; ++k) {
      n.min[k] = e.min[k];
      n.max[k] = e.max[k];
    }
  });
  return cost_of(area, nodes[0], nodes.size());
}

float refit(const BoxArray& boxes, std::span<BvhNode> nodes) {
  if (nodes.empty()) return 0;
  const double area =
      refit_parallel(nodes.data(), 0, static_cast<std::uint32_t>(nodes.size()), [&](BvhNode& n) {
        for (int k = 0; k < 3; ++k) {
          n.min[k] = boxes.min(k)[n.right];
          n.max[k] = boxes.max(k)[n.right];
        }
      });
  return cost_of(area, nodes[0], nodes.size());
}

float sah_cost(std::span<const BvhNode> nodes) {
  if (nodes.size() < 3) return 0;
  double area = 0;
  for (const BvhNode& n : nodes)
    if (!n.leaf()) area += node_area(n);
  return cost_of(area, nodes[0], nodes.size());
}

namespace {

// ---- edit(): incremental membership change, one job per function ----------
// The steps follow Box2D v3's dynamic tree (src/dynamic_tree.c): the tree is
// taken out of pre-order into a linked form (children and parents in
// s.left / s.right / s.parent, boxes in s.work), departed leaves are removed,
// newcomers are inserted next to the sibling that costs least and their
// ancestors enlarged, then the tree is written back in pre-order.

// Matches the old membership (old_ids) against the new (entries): s.remap[old
// entry] = new entry index or kNone (departed), s.added = new entries without
// an old one, in entry order. Returns false as soon as more than max_changes
// objects changed. Uses s.left / s.right as sort buffers.
bool diff_membership(std::span<const CellEntry> entries, std::span<const std::uint32_t> old_ids,
                     std::uint32_t max_changes, Scratch& s) {
  const auto old_count = static_cast<std::uint32_t>(old_ids.size());
  const auto new_count = static_cast<std::uint32_t>(entries.size());
  s.remap.assign(old_count, kNone);
  s.added.clear();
  std::uint32_t removed = 0;
  // Both lists in id order (cells come in min-x order), then one merge walk.
  std::vector<std::uint32_t>& old_by_id = s.left;
  std::vector<std::uint32_t>& new_by_id = s.right;
  old_by_id.resize(old_count);
  new_by_id.resize(new_count);
  for (std::uint32_t i = 0; i < old_count; ++i) old_by_id[i] = i;
  for (std::uint32_t j = 0; j < new_count; ++j) new_by_id[j] = j;
  std::sort(old_by_id.begin(), old_by_id.end(), [&](auto a, auto b) { return old_ids[a] < old_ids[b]; });
  std::sort(new_by_id.begin(), new_by_id.end(), [&](auto a, auto b) { return entries[a].id < entries[b].id; });
  std::uint32_t i = 0, j = 0;
  while (i < old_count || j < new_count) {
    if (j == new_count || (i < old_count && old_ids[old_by_id[i]] < entries[new_by_id[j]].id)) {
      ++removed;
      ++i;
    } else if (i == old_count || entries[new_by_id[j]].id < old_ids[old_by_id[i]]) {
      s.added.push_back(new_by_id[j++]);
    } else {
      s.remap[old_by_id[i++]] = new_by_id[j++];
    }
    if (removed + s.added.size() > max_changes) return false;
  }
  std::sort(s.added.begin(), s.added.end());  // newcomers inserted in entry order
  return true;
}

// Pre-order array -> linked form, slots = pre-order positions;
// s.leaf_of[old entry] = its leaf's slot. Returns the root slot.
std::uint32_t unflatten(std::span<const BvhNode> nodes, std::uint32_t old_count, Scratch& s) {
  const auto n = static_cast<std::uint32_t>(nodes.size());
  s.work.assign(nodes.begin(), nodes.end());
  s.left.assign(n, kNone);
  s.right.assign(n, kNone);
  s.parent.assign(n, kNone);
  s.leaf_of.assign(old_count, kNone);
  for (std::uint32_t i = 0; i < n; ++i) {
    if (nodes[i].leaf()) {
      s.leaf_of[nodes[i].right] = i;
    } else {
      s.left[i] = i + 1;
      s.right[i] = nodes[i].right;
      s.parent[i + 1] = i;
      s.parent[nodes[i].right] = i;
    }
  }
  return 0;
}

// A free slot of the linked form: one a removal freed (s.stack), else a new one.
std::uint32_t allocate_node(Scratch& s) {
  std::vector<std::uint32_t>& free_slots = s.stack;
  if (!free_slots.empty()) {
    const std::uint32_t slot = free_slots.back();
    free_slots.pop_back();
    return slot;
  }
  s.work.push_back(BvhNode{});
  s.left.push_back(kNone);
  s.right.push_back(kNone);
  s.parent.push_back(kNone);
  return static_cast<std::uint32_t>(s.work.size() - 1);
}

// In `parent` (or at the root when parent is kNone), `child` is replaced by
// `replacement`.
void replace_child(Scratch& s, std::uint32_t& root, std::uint32_t parent, std::uint32_t child,
                   std::uint32_t replacement) {
  if (parent == kNone) {
    root = replacement;
  } else if (s.left[parent] == child) {
    s.left[parent] = replacement;
  } else {
    s.right[parent] = replacement;
  }
}

// Unlinks a leaf: its sibling takes the parent's place; the leaf and the
// parent slots are freed (boxes above are left loose: refit follows).
void remove_leaf(Scratch& s, std::uint32_t& root, std::uint32_t leaf) {
  const std::uint32_t p = s.parent[leaf];
  s.stack.push_back(leaf);
  if (p == kNone) {
    root = kNone;
    return;
  }
  const std::uint32_t sibling = s.left[p] == leaf ? s.right[p] : s.left[p];
  const std::uint32_t g = s.parent[p];
  s.parent[sibling] = g;
  replace_child(s, root, g, p, sibling);
  s.stack.push_back(p);
}

// Where a new leaf goes: descends towards the child whose box grows least and
// stops where making the leaf this node's sibling is cheaper (surface-area
// cost of the insertion, as Box2D's b2FindBestSibling with a greedy descent).
std::uint32_t find_best_sibling(const Scratch& s, std::uint32_t root, std::uint32_t leaf) {
  std::uint32_t at = root;
  while (!s.work[at].leaf()) {
    BvhNode merged;
    set_union(merged, s.work[at], s.work[leaf]);
    const double merged_area = node_area(merged);
    const double here = 2 * merged_area;
    const double inherit = 2 * (merged_area - node_area(s.work[at]));
    auto descend_cost = [&](std::uint32_t c) {
      BvhNode u;
      set_union(u, s.work[c], s.work[leaf]);
      return inherit + node_area(u) - (s.work[c].leaf() ? 0.0 : node_area(s.work[c]));
    };
    const double cl = descend_cost(s.left[at]), cr = descend_cost(s.right[at]);
    if (here <= cl && here <= cr) break;
    at = cl <= cr ? s.left[at] : s.right[at];
  }
  return at;
}

// Every ancestor from `from` up grows to hold `leaf`'s box.
void enlarge_ancestors(Scratch& s, std::uint32_t from, std::uint32_t leaf) {
  for (std::uint32_t a = from; a != kNone; a = s.parent[a]) set_union(s.work[a], s.work[a], s.work[leaf]);
}

// Adds a leaf for entry e: a new parent joins it with its best sibling.
void insert_leaf(Scratch& s, std::uint32_t& root, std::span<const CellEntry> entries, std::uint32_t e) {
  const std::uint32_t leaf = allocate_node(s);
  BvhNode& ln = s.work[leaf];
  for (int k = 0; k < 3; ++k) {
    ln.min[k] = entries[e].min[k];
    ln.max[k] = entries[e].max[k];
  }
  ln.right = e;
  ln.object = entries[e].id;
  s.left[leaf] = s.right[leaf] = kNone;
  if (root == kNone) {
    root = leaf;
    s.parent[leaf] = kNone;
    return;
  }
  const std::uint32_t sibling = find_best_sibling(s, root, leaf);
  const std::uint32_t p = allocate_node(s);
  const std::uint32_t g = s.parent[sibling];
  BvhNode& pn = s.work[p];
  set_union(pn, s.work[sibling], s.work[leaf]);
  pn.object = BvhNode::kInternal;
  s.left[p] = sibling;
  s.right[p] = leaf;
  s.parent[p] = g;
  s.parent[sibling] = p;
  s.parent[leaf] = p;
  replace_child(s, root, g, sibling, p);
  enlarge_ancestors(s, g, leaf);
}

// Linked form -> pre-order array of 2 * leaves - 1 nodes. Uses s.leaf_of as
// the stack (free once the removals are done).
void flatten(Scratch& s, std::uint32_t root, std::uint32_t leaves, std::vector<BvhNode>& nodes) {
  nodes.resize(2 * static_cast<std::size_t>(leaves) - 1);
  std::uint32_t out = 0;
  // (slot, position of the parent whose `right` it is) pairs.
  std::vector<std::uint32_t>& stack = s.leaf_of;
  stack.clear();
  stack.push_back(root);
  stack.push_back(kNone);
  while (!stack.empty()) {
    const std::uint32_t parent_pos = stack.back();
    stack.pop_back();
    const std::uint32_t slot = stack.back();
    stack.pop_back();
    const std::uint32_t pos = out++;
    if (parent_pos != kNone) nodes[parent_pos].right = pos;  // right children are pushed first, visited last
    BvhNode& dst = nodes[pos];
    dst = s.work[slot];
    if (!dst.leaf()) {
      stack.push_back(s.right[slot]);
      stack.push_back(pos);  // fix up this node's `right` when the right child is placed
      stack.push_back(s.left[slot]);
      stack.push_back(kNone);  // the left child is implicit (pos + 1)
    }
  }
}

}  // namespace

bool edit(std::span<const CellEntry> entries, std::span<const std::uint32_t> old_ids, std::vector<BvhNode>& nodes,
          std::uint32_t max_changes, Scratch& s) {
  if (!diff_membership(entries, old_ids, max_changes, s)) return false;
  const auto old_count = static_cast<std::uint32_t>(old_ids.size());
  const auto new_count = static_cast<std::uint32_t>(entries.size());
  if (new_count == 0 || old_count == 0) return false;

  std::uint32_t root = unflatten(nodes, old_count, s);
  s.stack.clear();  // free slots
  for (std::uint32_t i = 0; i < old_count; ++i)
    if (s.remap[i] == kNone) remove_leaf(s, root, s.leaf_of[i]);
  // Survivors' entry indices follow the new numbering.
  for (std::uint32_t i = 0; i < old_count; ++i)
    if (s.remap[i] != kNone) s.work[s.leaf_of[i]].right = s.remap[i];
  for (std::uint32_t e : s.added) insert_leaf(s, root, entries, e);
  flatten(s, root, new_count, nodes);
  return true;
}

}  // namespace hbp::bvh
