// SPDX-License-Identifier: MIT
#include "pipeline/box_tree.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "hierarchy/cell_bvh.hpp"

namespace hbp::detail {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

float half_area(const BvhNode& b) {
  const float x = b.max[0] - b.min[0], y = b.max[1] - b.min[1], z = b.max[2] - b.min[2];
  return x * y + y * z + z * x;
}

struct Box {
  float min[3];
  float max[3];
};

float decode_bound(float lo, std::uint32_t q, float step) { return lo + static_cast<float>(q) * step; }

// Sets n's lo, step and the quantised bounds of its `used` children from
// their boxes, rounded outward and verified with the decoding arithmetic, so
// that every decoded box contains its child's box.
void quantise(BoxTree::Node& n, const Box* kids, std::uint32_t used) {
  for (int k = 0; k < 3; ++k) {
    float lo = kInf, hi = -kInf;
    for (std::uint32_t c = 0; c < used; ++c) {
      lo = std::min(lo, kids[c].min[k]);
      hi = std::max(hi, kids[c].max[k]);
    }
    // The step: (hi - lo) / 255 (in double: no overflow on huge boxes), then
    // grown until the top code reaches hi in float. It stays finite: at most
    // twice the ~2.7e36 the widest float range needs.
    float step = static_cast<float>((static_cast<double>(hi) - lo) / 255.0);
    for (int i = 0; !(decode_bound(lo, 255, step) >= hi); ++i) {
      if (i == 300)  // finite boxes converge in a few steps (build() rejects the others)
        throw std::logic_error("BoxTree: no quantisation step covers [" + std::to_string(lo) + ", " +
                               std::to_string(hi) + "]");
      step = step == 0 ? std::numeric_limits<float>::denorm_min() : i < 4 ? std::nextafter(step, kInf) : 2 * step;
    }
    n.lo[k] = lo;
    n.step[k] = step;
    for (std::uint32_t c = 0; c < BoxTree::kNodeWidth; ++c) {
      if (c >= used) {
        n.qmin[k][c] = n.qmax[k][c] = 0;
        continue;
      }
      const float mn = kids[c].min[k], mx = kids[c].max[k];
      std::uint32_t qmin = 0, qmax = 255;
      if (step > 0) {
        const double scale = 1.0 / step;
        qmin = static_cast<std::uint32_t>(std::clamp(std::floor((static_cast<double>(mn) - lo) * scale), 0.0, 255.0));
        qmax = static_cast<std::uint32_t>(std::clamp(std::ceil((static_cast<double>(mx) - lo) * scale), 0.0, 255.0));
      }
      // Outward: decoded min <= mn (code 0 decodes to lo <= mn), decoded max
      // >= mx (code 255 reaches hi >= mx); then as tight as that allows.
      while (qmin > 0 && decode_bound(lo, qmin, step) > mn) --qmin;
      while (qmin < 255 && decode_bound(lo, qmin + 1, step) <= mn) ++qmin;
      while (qmax < 255 && decode_bound(lo, qmax, step) < mx) ++qmax;
      while (qmax > 0 && decode_bound(lo, qmax - 1, step) >= mx) --qmax;
      n.qmin[k][c] = static_cast<std::uint8_t>(qmin);
      n.qmax[k][c] = static_cast<std::uint8_t>(qmax);
    }
  }
}

// Union of a leaf's used lanes / a node's decoded lanes.
Box bounds(const BoxTree::Leaf& l) {
  Box b{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};
  for (std::uint32_t c = 0; c < BoxTree::kWidth; ++c)
    for (int k = 0; k < 3; ++k) {  // unused lanes are the empty box
      b.min[k] = std::min(b.min[k], l.min[k][c]);
      b.max[k] = std::max(b.max[k], l.max[k][c]);
    }
  return b;
}
// A decoded bound can pass the float range (the top code of a node spanning
// [-FLT_MAX, FLT_MAX] decodes to +inf): clamped to it, the union still
// contains every box below (all finite), and the parent's range, hence its
// step, stays finite (an infinite step decodes code 0 as 0 * inf = NaN).
Box bounds(const BoxTree::Node& n) {
  constexpr float kMax = std::numeric_limits<float>::max();
  Box b{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};
  for (std::uint32_t c = 0; c < BoxTree::kNodeWidth; ++c) {
    if (n.link[c] == BoxTree::kNone) continue;
    float mn[3], mx[3];
    BoxTree::decode(n, c, mn, mx);
    for (int k = 0; k < 3; ++k) {
      b.min[k] = std::min(b.min[k], std::max(mn[k], -kMax));
      b.max[k] = std::max(b.max[k], std::min(mx[k], kMax));
    }
  }
  return b;
}

void set_lane(BoxTree::Leaf& l, std::uint32_t c, const BoxArray& boxes, std::uint32_t o) {
  for (int k = 0; k < 3; ++k) {
    l.min[k][c] = boxes.min(k)[o];
    l.max[k][c] = boxes.max(k)[o];
  }
}

}  // namespace

void BoxTree::build(const BoxArray& boxes, std::span<const std::uint32_t> ids) {
  clear();
  if (boxes.size() == 0) return;
  if (boxes.size() >= kMaxBoxes || ids.size() != boxes.size())
    throw std::length_error("BoxTree::build: more than 2^31 - 1 boxes, or ids not one per box");
  // The quantisation needs finite, ordered boxes (BroadPhase rejects others
  // at add / move; this guards the class itself).
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (const char* d = box_defect(boxes.get(i)))
      throw std::invalid_argument("BoxTree::build: box " + std::to_string(i) + ": " + d);
  // The binary tree (and the builder's scratch) live only during the build.
  std::vector<BvhNode> bin;
  {
    bvh::Scratch scratch;
    bvh::build(boxes, bin, scratch);
  }
  // Objects under each binary node (pre-order: children after the parent).
  std::vector<std::uint32_t> count(bin.size());
  for (std::size_t i = bin.size(); i-- > 0;)
    count[i] = bin[i].leaf() ? 1 : count[i + 1] + count[bin[i].right];
  // Exactly one leaf per binary subtree of <= kWidth objects under one of
  // more; fewer nodes than leaves (the excess is given back at the end).
  std::size_t leaf_count = count[0] <= kWidth ? 1 : 0;
  for (std::size_t i = 0; i < bin.size(); ++i)
    if (count[i] > kWidth) leaf_count += (count[i + 1] <= kWidth) + (count[bin[i].right] <= kWidth);
  // grow() on the empty buffers (clear() above) allocates exactly this much.
  leaves_.grow(leaf_count);
  nodes_.grow(leaf_count);  // >= 2 children per node: fewer nodes than leaves
  std::uint32_t leaves = 0, nodes = 0;
  // A binary subtree of <= kWidth objects becomes one leaf.
  std::vector<std::uint32_t> walk;
  const auto emit_leaf = [&](std::uint32_t b) {
    Leaf l;
    for (std::uint32_t c = 0; c < kWidth; ++c)
      for (int k = 0; k < 3; ++k) {
        l.min[k][c] = kInf;
        l.max[k][c] = -kInf;
      }
    std::fill(l.index, l.index + kWidth, kNone);
    std::fill(l.id, l.id + kWidth, 0u);
    std::uint32_t used = 0;
    walk.assign(1, b);
    while (!walk.empty()) {
      const std::uint32_t i = walk.back();
      walk.pop_back();
      if (!bin[i].leaf()) {
        walk.push_back(bin[i].right);
        walk.push_back(i + 1);
        continue;
      }
      const std::uint32_t o = bin[i].object;
      set_lane(l, used, boxes, o);
      l.index[used] = o;
      l.id[used] = ids[o];
      ++used;
    }
    leaves_[leaves] = l;
    return kLeaf | leaves++;
  };
  if (count[0] <= kWidth) {
    nodes_.truncate(0);
    root_ = emit_leaf(0);
    return;
  }
  root_ = 0;
  // Emit nodes in pre-order (a node before its descendants, so refit runs
  // backwards) with an explicit stack of (binary node, parent lane whose
  // link must point at it).
  struct Todo {
    std::uint32_t bin;
    std::uint32_t parent;  // node index, or kNone for the root
    std::uint32_t lane;
  };
  std::vector<Todo> todo{{0, kNone, 0}};
  while (!todo.empty()) {
    const Todo t = todo.back();
    todo.pop_back();
    const std::uint32_t me = nodes++;
    if (t.parent != kNone) nodes_[t.parent].link[t.lane] = me;
    // Open the binary subtree: replace a child that is not yet a leaf (more
    // than kWidth objects) by its two children while fewer than eight:
    // first those of at most three leaves' worth of objects (left closed they
    // would become nodes of two or three leaves: 78k nodes instead of 106k,
    // and faster queries, on the paper frame), then the one of largest area.
    std::uint32_t kids[kNodeWidth] = {t.bin};
    std::uint32_t used = 1;
    while (used < kNodeWidth) {
      int best = -1;
      float best_area = -1;
      for (std::uint32_t c = 0; c < used; ++c) {
        if (count[kids[c]] <= kWidth) continue;
        const float area = count[kids[c]] <= 3 * kWidth ? kInf : half_area(bin[kids[c]]);
        if (area > best_area) {
          best = static_cast<int>(c);
          best_area = area;
        }
      }
      if (best < 0) break;
      const std::uint32_t b = kids[best];
      kids[best] = b + 1;
      kids[used++] = bin[b].right;
    }
    Node n;
    Box kid_box[kNodeWidth];
    for (std::uint32_t c = 0; c < kNodeWidth; ++c) {
      n.link[c] = kNone;
      if (c >= used) continue;
      for (int k = 0; k < 3; ++k) {
        kid_box[c].min[k] = bin[kids[c]].min[k];
        kid_box[c].max[k] = bin[kids[c]].max[k];
      }
      // Leaf children now, side by side.
      if (count[kids[c]] <= kWidth) n.link[c] = emit_leaf(kids[c]);
    }
    quantise(n, kid_box, used);
    nodes_[me] = n;
    // Node children, the first on top (visited first, laid out next).
    for (std::uint32_t c = used; c-- > 0;)
      if (n.link[c] == kNone) todo.push_back({kids[c], me, c});
  }
  // Give the excess back: an exact copy.
  RawBuffer<Node> exact;
  exact.grow(nodes);
  std::memcpy(exact.data(), nodes_.data(), nodes * sizeof(Node));
  nodes_.swap(exact);
}

void BoxTree::refit(const BoxArray& boxes) {
  for (std::size_t i = 0; i < leaves_.size(); ++i)
    for (std::uint32_t c = 0; c < kWidth; ++c)
      if (leaves_[i].index[c] != kNone) set_lane(leaves_[i], c, boxes, leaves_[i].index[c]);
  for (std::size_t i = nodes_.size(); i-- > 0;) {  // children after parents
    Node& n = nodes_[i];
    Box kid_box[kNodeWidth];
    std::uint32_t used = 0;
    while (used < kNodeWidth && n.link[used] != kNone) {
      const std::uint32_t link = n.link[used];
      kid_box[used] = link & kLeaf ? bounds(leaves_[link & ~kLeaf]) : bounds(nodes_[link]);
      ++used;
    }
    quantise(n, kid_box, used);
  }
}

std::uint32_t BoxTree::depth() const {
  if (empty()) return 0;
  if (root_ & kLeaf) return 1;
  // Pre-order: a node's depth is known before its children's.
  std::vector<std::uint32_t> level(nodes_.size());
  std::uint32_t deepest = 0;
  level[0] = 1;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    for (std::uint32_t link : nodes_[i].link) {
      if (link == kNone) continue;
      if (link & kLeaf)
        deepest = std::max(deepest, level[i] + 1);
      else
        level[link] = level[i] + 1;
    }
  return deepest;
}

void BoxTree::clear() {
  RawBuffer<Node>().swap(nodes_);
  RawBuffer<Leaf>().swap(leaves_);
  root_ = kNone;
}

}  // namespace hbp::detail
