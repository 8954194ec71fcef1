#include "pipeline/box_tree.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include "hierarchy/cell_bvh.hpp"

namespace hbp::detail {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

float half_area(const BvhNode& b) {
  const float x = b.max[0] - b.min[0], y = b.max[1] - b.min[1], z = b.max[2] - b.min[2];
  return x * y + y * z + z * x;
}

}  // namespace

void BoxTree::build(const BoxArray& boxes, std::span<const std::uint32_t> ids) {
  nodes_.clear();
  if (boxes.size() == 0) return;
  if (boxes.size() >= kMaxBoxes || ids.size() != boxes.size())
    throw std::length_error("BoxTree::build: more than 2^31 - 1 boxes, or ids not one per box");
  // The binary tree (and the builder's scratch) live only during the build.
  std::vector<BvhNode> bin;
  {
    bvh::Scratch scratch;
    bvh::build(boxes, bin, scratch);
  }
  nodes_.reserve(bin.size() / 5 + 1);
  // Emit 4-wide nodes in pre-order (a node before its descendants, so refit
  // runs backwards) with an explicit stack of (binary node, parent lane
  // whose link must point at it).
  struct Todo {
    std::uint32_t bin;
    std::uint32_t parent;  // node index, or ~0 for the root
    std::uint32_t lane;
  };
  std::vector<Todo> todo{{0, ~0u, 0}};
  while (!todo.empty()) {
    const Todo t = todo.back();
    todo.pop_back();
    const auto me = static_cast<std::uint32_t>(nodes_.size());
    if (t.parent != ~0u) nodes_[t.parent].link[t.lane] = me;
    // Open the binary subtree: replace the internal child of largest area
    // by its two children while fewer than four. (A lone object at the
    // root becomes a node of one lane.)
    std::uint32_t kids[kWidth] = {t.bin, 0, 0, 0};
    std::uint32_t used = 1;
    while (used < kWidth) {
      int best = -1;
      float best_area = -1;
      for (std::uint32_t c = 0; c < used; ++c)
        if (!bin[kids[c]].leaf() && half_area(bin[kids[c]]) > best_area) {
          best = static_cast<int>(c);
          best_area = half_area(bin[kids[c]]);
        }
      if (best < 0) break;
      const std::uint32_t b = kids[best];
      kids[best] = b + 1;
      kids[used++] = bin[b].right;
    }
    Node n;
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const bool real = c < used;
      const BvhNode& b = bin[kids[real ? c : 0]];
      for (int k = 0; k < 3; ++k) {
        n.min[k][c] = real ? b.min[k] : kInf;
        n.max[k][c] = real ? b.max[k] : -kInf;
      }
      n.link[c] = real && b.leaf() ? kObject | b.object : 0;
      n.id[c] = real && b.leaf() ? ids[b.object] : 0;
    }
    nodes_.push_back(n);
    // Internal children, the first on top (visited first, laid out next).
    for (std::uint32_t c = used; c-- > 0;)
      if (!bin[kids[c]].leaf()) todo.push_back({kids[c], me, c});
  }
}

void BoxTree::refit(const BoxArray& boxes) {
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    Node& n = nodes_[i];
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const std::uint32_t link = n.link[c];
      if (link == 0) continue;
      if (link & kObject) {
        const std::uint32_t o = link & ~kObject;
        for (int k = 0; k < 3; ++k) {
          n.min[k][c] = boxes.min(k)[o];
          n.max[k][c] = boxes.max(k)[o];
        }
        continue;
      }
      const Node& d = nodes_[link];  // after n: already refitted (unused lanes are empty)
      for (int k = 0; k < 3; ++k) {
        float mn = d.min[k][0], mx = d.max[k][0];
        for (std::uint32_t j = 1; j < kWidth; ++j) {
          mn = std::min(mn, d.min[k][j]);
          mx = std::max(mx, d.max[k][j]);
        }
        n.min[k][c] = mn;
        n.max[k][c] = mx;
      }
    }
  }
}

void BoxTree::clear() { std::vector<Node>().swap(nodes_); }

}  // namespace hbp::detail
