// SPDX-License-Identifier: MIT
#include "hbp/validated_boxes.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "geometry/box_screen.hpp"
#include "pipeline/screened_boxes.hpp"

namespace hbp {

namespace detail {

void screen_boxes(const BoxArray& boxes, const char* what) {
  const bool bad = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, boxes.size(), 16384), false,
      [&](const auto& r, bool acc) { return acc || geometry::screen_fails(boxes, r.begin(), r.end()); },
      [](bool a, bool b) { return a || b; });
  if (bad) boxes.validate(what);
}

void screen_boxes_serial(const BoxArray& boxes, const char* what) {
  if (geometry::screen_fails(boxes, 0, boxes.size())) boxes.validate(what);
}

}  // namespace detail

ValidatedBoxes::ValidatedBoxes(const BoxArray& boxes) : boxes_(&boxes) { detail::screen_boxes(boxes, "boxes"); }

}  // namespace hbp
