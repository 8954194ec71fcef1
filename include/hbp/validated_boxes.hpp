// SPDX-License-Identifier: MIT
#pragma once
// Boxes known to pass the box screen: every coordinate finite, min <= max on
// every axis. HybridBroadPhase::update takes them without a screen of its
// own. The type is had only by screening: its constructor screens the whole
// array, and its one other maker, BroadPhase's store of moving boxes
// (src/pipeline/screened_boxes.hpp), screens every box it writes.
#include "hbp/box_array.hpp"

namespace hbp {

namespace detail {
class ScreenedBoxes;
}

class ValidatedBoxes {
 public:
  // Screens every box of `boxes` (in parallel when large); InvalidInput
  // names the first bad object. A view: `boxes` must outlive it, unchanged.
  explicit ValidatedBoxes(const BoxArray& boxes);
  const BoxArray& boxes() const { return *boxes_; }

 private:
  friend class detail::ScreenedBoxes;
  struct Screened {};
  ValidatedBoxes(const BoxArray& boxes, Screened) : boxes_(&boxes) {}
  const BoxArray* boxes_;
};

}  // namespace hbp
