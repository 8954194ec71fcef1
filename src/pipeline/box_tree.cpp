#include "pipeline/box_tree.hpp"

#include <algorithm>
#include <limits>

#include "hierarchy/cell_bvh.hpp"

namespace hbp::detail {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

float half_area(const BvhNode& b) {
  const float x = b.max[0] - b.min[0], y = b.max[1] - b.min[1], z = b.max[2] - b.min[2];
  return x * y + y * z + z * x;
}

void set_empty(BoxTree::Node& n, std::uint32_t c) {
  for (int k = 0; k < 3; ++k) {
    n.min[k][c] = kInf;
    n.max[k][c] = -kInf;
  }
  n.link[c] = 0;
  n.count[c] = 0;
}

// The union of `count` items into child slot c.
void fit_items(BoxTree::Node& n, std::uint32_t c, const BoxTree::Item* items, std::uint32_t count) {
  for (int k = 0; k < 3; ++k) {
    float mn = items[0].min[k], mx = items[0].max[k];
    for (std::uint32_t j = 1; j < count; ++j) {
      mn = std::min(mn, items[j].min[k]);
      mx = std::max(mx, items[j].max[k]);
    }
    n.min[k][c] = mn;
    n.max[k][c] = mx;
  }
}

}  // namespace

void BoxTree::build(const BoxArray& boxes, std::span<const std::uint32_t> ids) {
  nodes_.clear();
  items_.clear();
  if (boxes.size() == 0) return;
  // The binary tree (and the builder's scratch) live only during the build.
  std::vector<BvhNode> bin;
  {
    bvh::Scratch scratch;
    bvh::build(boxes, bin, scratch);
  }
  const auto count = static_cast<std::uint32_t>(bin.size());
  // Leaves under each node (pre-order: children follow their parent).
  std::vector<std::uint32_t> leaves(count);
  for (std::uint32_t i = count; i-- > 0;)
    leaves[i] = bin[i].leaf() ? 1 : leaves[i + 1] + leaves[bin[i].right];

  items_.reserve(boxes.size());
  // The items of the binary subtree at b (at most kLeafSize leaves: the next
  // 2k - 1 binary nodes), appended; returns the first.
  const auto emit_items = [&](std::uint32_t b) {
    const auto first = static_cast<std::uint32_t>(items_.size());
    const std::uint32_t end = b + 2 * leaves[b] - 1;
    for (std::uint32_t j = b; j < end; ++j)
      if (bin[j].leaf()) {
        const BvhNode& l = bin[j];
        items_.push_back({{l.min[0], l.min[1], l.min[2]}, {l.max[0], l.max[1], l.max[2]}, l.object, ids[l.object]});
      }
    return first;
  };
  if (leaves[0] <= kLeafSize) {  // one leaf, no node
    emit_items(0);
    return;
  }

  nodes_.reserve(leaves[0] / 6 + 1);
  // Emit 4-wide nodes in pre-order (a node before its descendants, so refit
  // runs backwards) with an explicit stack of (binary node, parent slot whose
  // link must point at it).
  struct Todo {
    std::uint32_t bin;
    std::uint32_t parent;  // node index, or ~0 for the root
    std::uint32_t slot;
  };
  std::vector<Todo> todo{{0, ~0u, 0}};
  while (!todo.empty()) {
    const Todo t = todo.back();
    todo.pop_back();
    const auto me = static_cast<std::uint32_t>(nodes_.size());
    if (t.parent != ~0u) nodes_[t.parent].link[t.slot] = me;
    // Open the binary subtree: replace the openable child (more than a
    // leaf's worth of boxes) of largest area by its two children until four.
    std::uint32_t kids[kWidth] = {t.bin + 1, bin[t.bin].right, 0, 0};
    std::uint32_t used = 2;
    while (used < kWidth) {
      int best = -1;
      float best_area = -1;
      for (std::uint32_t c = 0; c < used; ++c)
        if (leaves[kids[c]] > kLeafSize && half_area(bin[kids[c]]) > best_area) {
          best = static_cast<int>(c);
          best_area = half_area(bin[kids[c]]);
        }
      if (best < 0) break;
      const std::uint32_t b = kids[best];
      kids[best] = b + 1;
      kids[used++] = bin[b].right;
    }
    Node n{};
    n.used = used;
    for (std::uint32_t c = 0; c < kWidth; ++c) set_empty(n, c);
    for (std::uint32_t c = 0; c < used; ++c) {
      const BvhNode& b = bin[kids[c]];
      for (int k = 0; k < 3; ++k) {
        n.min[k][c] = b.min[k];
        n.max[k][c] = b.max[k];
      }
      if (leaves[kids[c]] <= kLeafSize) {
        n.count[c] = static_cast<std::uint8_t>(leaves[kids[c]]);
        n.link[c] = emit_items(kids[c]);
      }
    }
    nodes_.push_back(n);
    // Internal children, the first on top (visited first, laid out next).
    for (std::uint32_t c = used; c-- > 0;)
      if (leaves[kids[c]] > kLeafSize) todo.push_back({kids[c], me, c});
  }
}

void BoxTree::refit(const BoxArray& boxes) {
  for (Item& it : items_)
    for (int k = 0; k < 3; ++k) {
      it.min[k] = boxes.min(k)[it.index];
      it.max[k] = boxes.max(k)[it.index];
    }
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    Node& n = nodes_[i];
    for (std::uint32_t c = 0; c < n.used; ++c) {
      if (n.count[c]) {
        fit_items(n, c, &items_[n.link[c]], n.count[c]);
        continue;
      }
      const Node& d = nodes_[n.link[c]];  // after n: already refitted
      for (int k = 0; k < 3; ++k) {
        float mn = d.min[k][0], mx = d.max[k][0];
        for (std::uint32_t j = 1; j < d.used; ++j) {
          mn = std::min(mn, d.min[k][j]);
          mx = std::max(mx, d.max[k][j]);
        }
        n.min[k][c] = mn;
        n.max[k][c] = mx;
      }
    }
  }
}

void BoxTree::clear() {
  std::vector<Node>().swap(nodes_);
  std::vector<Item>().swap(items_);
}

}  // namespace hbp::detail
