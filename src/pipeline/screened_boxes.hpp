// SPDX-License-Identifier: MIT
#pragma once
// A box array every box of which passed the box screen, kept so by its only
// writers: set() screens the box it writes, assign() the whole array,
// transpose() each row as it writes it (one pass over a move() batch). So a
// ValidatedBoxes view of it needs no screen: BroadPhase keeps its moving
// boxes here and hands the view to the hybrid system each frame.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "geometry/box_screen.hpp"
#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/error.hpp"
#include "hbp/validated_boxes.hpp"
#include "pipeline/box_transpose.hpp"
#include "support/retained.hpp"

namespace hbp::detail {

// The frame's boxes screened in parallel (chunks of 16,384 boxes) or on the
// calling thread; on failure the serial BoxArray::validate names the object.
void screen_boxes(const BoxArray& boxes, const char* what = "frame");
void screen_boxes_serial(const BoxArray& boxes, const char* what = "frame");

class ScreenedBoxes {
 public:
  const BoxArray& boxes() const { return boxes_; }
  ValidatedBoxes view() const { return ValidatedBoxes(boxes_, ValidatedBoxes::Screened{}); }
  std::size_t size() const { return boxes_.size(); }
  Aabb get(std::size_t i) const { return boxes_.get(i); }
  void reserve(std::size_t n) { boxes_.reserve(n); }

  // Box i replaced by `box`; InvalidInput (nothing changed) when it fails
  // the screen.
  void set(std::size_t i, const Aabb& box) {
    if (geometry::screen_fails(&box, 0, 1)) throw InvalidInput("box " + std::to_string(i) + " fails the box screen");
    boxes_.set(i, box);
  }

  // The array, taken out to be rebuilt (this holds none until assign).
  BoxArray take() { return std::move(boxes_); }
  // The whole array replaced by `boxes`, all screened first (InvalidInput
  // names the first bad one; nothing changed).
  void assign(BoxArray&& boxes) {
    screen_boxes(boxes, "boxes");
    boxes_ = std::move(boxes);
  }

  // Every box replaced by boxes[0, n) in one pass that screens each row as
  // it writes it (check_and_transpose: the rows' ids checked against
  // `expected` in the same pass, see box_transpose.hpp) into a staging
  // array, swapped in only when every row passed; false (nothing changed)
  // otherwise. `ranges(n, body)` runs body(begin, end) over ranges of
  // [0, n) and returns the sum of the results. `changed`: the rows whose box
  // differs from the one it replaces, which replaced() then holds.
  template <class Ranges>
  bool transpose(const Aabb* boxes, const std::uint32_t* ids, const std::uint32_t* expected, std::size_t n,
                 bool stream, Ranges&& ranges, std::uint32_t& changed) {
    staged_.resize(n);
    float* lane[6];
    const float* previous[6];
    for (int k = 0; k < 3; ++k) {
      lane[k] = staged_.min(k);
      lane[3 + k] = staged_.max(k);
      previous[k] = boxes_.min(k);
      previous[3 + k] = boxes_.max(k);
    }
    // Low 32 bits: ranges that failed; high 32: boxes that changed.
    const std::uint64_t outcome = ranges(n, [&](std::size_t begin, std::size_t end) {
      std::uint32_t c = 0;
      const bool ok = check_and_transpose(boxes, ids, expected, begin, end, lane, stream, previous, &c);
      return std::uint64_t(!ok) | std::uint64_t(c) << 32;
    });
    if (outcome & 0xFFFFFFFFu) return false;
    std::swap(boxes_, staged_);
    changed = static_cast<std::uint32_t>(outcome >> 32);
    return true;
  }
  // The boxes the last transpose replaced, in the same order (until the
  // next transpose or trim_staging).
  const BoxArray& replaced() const { return staged_; }
  // The staging array given back when far larger than n boxes need.
  void trim_staging(std::size_t n) {
    if (retained::oversized(staged_.capacity(), n, retained::kSlack<Aabb>)) staged_ = BoxArray();
  }
  // Both arrays given back.
  void release() {
    boxes_ = BoxArray();
    staged_ = BoxArray();
  }

 private:
  BoxArray boxes_;
  BoxArray staged_;
};

}  // namespace hbp::detail
