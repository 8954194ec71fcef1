// SPDX-License-Identifier: MIT
#pragma once
// A Karras-style linear BVH as a peer: Morton codes of the box centres
// (10 bits per axis, quantized in the scene's bounds) with the object index
// as the low word, so the keys are unique and the order total; a radix sort;
// the radix tree of Karras (2012) over the sorted keys (n - 1 internal
// nodes, n leaves) with node bounds refitted bottom-up; then a thread per
// leaf (position p in sorted order) walking the tree with a fixed stack,
// pruning subtrees whose bounds miss its box and subtrees whose leaves all
// lie at positions <= p, so each pair is found once, by its earlier leaf.
// Exact (closed intervals on all three axes), counted before written so none
// is dropped and max_pairs gives CapacityExceeded, on the CPU launcher or a
// CUDA device, with the frame's options.
//
// FrameInfo: refs/cells/large/grid are 0. Stage times: bounds_ms the
// scene's bounds; sort_ms Morton keys, sort, gather of the sorted boxes;
// refs_ms tree build and bounds refit; count_ms the traversals counting and
// the scan; fill_ms the traversals writing; order_ms the (a, b) sort.
#include <memory>
#include <vector>

#include "hbp/cuda/frame_broadphase.hpp"

namespace hbp::cuda {

class Lbvh {
 public:
  explicit Lbvh(const FrameOptions& options = {});  // Device: "no CUDA device found" when none
  ~Lbvh();
  Lbvh(Lbvh&&) noexcept;
  Lbvh& operator=(Lbvh&&) noexcept;
  // Canonical pairs (a < b), ordered by (a, b) when options.sorted, else in
  // traversal order (leaf by leaf in Morton order), the same on both
  // launchers and for any thread count.
  const std::vector<Pair>& update(const Lanes& boxes);
  const FrameInfo& info() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp::cuda
