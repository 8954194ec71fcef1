#include "pipeline/box_tree.hpp"

#include "partition/cell_bvh.hpp"

namespace hbp::detail {

void BoxTree::build(const BoxArray& boxes) {
  // The build's scratch (about 40 bytes per box) is dropped afterwards:
  // statics rebuild rarely, and memory follows the current needs.
  bvh::Scratch scratch;
  bvh::build(boxes, nodes_, scratch);
  if (nodes_.capacity() > 2 * nodes_.size() + 64) nodes_.shrink_to_fit();
}

void BoxTree::refit(const BoxArray& boxes) { bvh::refit(boxes, nodes_); }

void BoxTree::clear() {
  nodes_.clear();
  nodes_.shrink_to_fit();
}

}  // namespace hbp::detail
