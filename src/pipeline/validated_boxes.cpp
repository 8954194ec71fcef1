// SPDX-License-Identifier: MIT
#include "hbp/validated_boxes.hpp"

#include "geometry/box_screen.hpp"
#include "pipeline/screened_boxes.hpp"
#include "support/parallel_for.hpp"

namespace hbp {

namespace detail {

void screen_boxes(const BoxArray& boxes, const char* what) {
  const bool bad = parallel_reduce(
      boxes.size(), 16384, false,
      [&](std::size_t begin, std::size_t end, bool acc) { return acc || geometry::screen_fails(boxes, begin, end); },
      [](bool a, bool b) { return a || b; });
  if (bad) boxes.validate(what);
}

void screen_boxes_serial(const BoxArray& boxes, const char* what) {
  if (geometry::screen_fails(boxes, 0, boxes.size())) boxes.validate(what);
}

}  // namespace detail

ValidatedBoxes::ValidatedBoxes(const BoxArray& boxes) : boxes_(&boxes) { detail::screen_boxes(boxes, "boxes"); }

}  // namespace hbp
