#include "pipeline/box_tree.hpp"

#include <algorithm>

#include "hierarchy/cell_bvh.hpp"

namespace hbp::detail {

namespace {

void set_union(BoxTree::Node& n, const float* mn, const float* mx) {
  for (int k = 0; k < 3; ++k) {
    n.min[k] = std::min(n.min[k], mn[k]);
    n.max[k] = std::max(n.max[k], mx[k]);
  }
}

}  // namespace

void BoxTree::build(const BoxArray& boxes) {
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

  nodes_.reserve(count / 2 + 1);
  items_.reserve(boxes.size());
  // Emit in pre-order with an explicit stack of (binary node, parent slot
  // whose link must point at it).
  struct Todo {
    std::uint32_t bin;
    std::uint32_t patch;  // node whose link becomes this node's index, or ~0
  };
  std::vector<Todo> todo{{0, ~0u}};
  while (!todo.empty()) {
    const Todo t = todo.back();
    todo.pop_back();
    const auto me = static_cast<std::uint32_t>(nodes_.size());
    if (t.patch != ~0u) nodes_[t.patch].link = me;
    const BvhNode& b = bin[t.bin];
    Node n{{b.min[0], b.min[1], b.min[2]}, 0, {b.max[0], b.max[1], b.max[2]}, 0};
    if (leaves[t.bin] <= kLeafSize) {
      // The subtree's leaves are the next 2k - 1 binary nodes.
      n.link = static_cast<std::uint32_t>(items_.size());
      n.count = leaves[t.bin];
      const std::uint32_t end = t.bin + 2 * leaves[t.bin] - 1;
      for (std::uint32_t j = t.bin; j < end; ++j)
        if (bin[j].leaf()) {
          const BvhNode& l = bin[j];
          items_.push_back({{l.min[0], l.min[1], l.min[2]}, {l.max[0], l.max[1], l.max[2]}, l.object});
        }
      nodes_.push_back(n);
      continue;
    }
    nodes_.push_back(n);
    todo.push_back({b.right, me});   // right child after the whole left subtree
    todo.push_back({t.bin + 1, ~0u});  // left child next
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
    const std::uint32_t link = n.link, count = n.count;
    if (count) {
      for (int k = 0; k < 3; ++k) {
        n.min[k] = items_[link].min[k];
        n.max[k] = items_[link].max[k];
      }
      for (std::uint32_t j = link + 1; j < link + count; ++j) set_union(n, items_[j].min, items_[j].max);
    } else {
      const Node& l = nodes_[i + 1];
      const Node& r = nodes_[link];
      for (int k = 0; k < 3; ++k) {
        n.min[k] = std::min(l.min[k], r.min[k]);
        n.max[k] = std::max(l.max[k], r.max[k]);
      }
    }
  }
}

void BoxTree::clear() {
  std::vector<Node>().swap(nodes_);
  std::vector<Item>().swap(items_);
}

}  // namespace hbp::detail
