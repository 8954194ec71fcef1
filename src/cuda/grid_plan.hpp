// SPDX-License-Identifier: MIT
#pragma once
// The frame's uniform grid, planned on the host from the boxes' bounds and
// count and kept across frames while they stay close to what it was planned
// for. A kept grid is always correct (its outer cells are unbounded); it is
// replanned only for speed. The planes are floats computed once here, and
// every launcher compares against these same values.
#include <cstdint>
#include <vector>

#include "cuda/frame_bodies.hpp"
#include "hbp/cuda/frame_broadphase.hpp"

namespace hbp::cuda {

struct Bounds {
  float lo[3];
  float hi[3];
};

// How many boxes have their extent on axis k in each extent_bin.
struct ExtentHistogram {
  std::uint32_t count[3][kExtentBins];
};

class GridPlan {
 public:
  GridPlan();
  // Plans anew when there is no plan yet, n left [3/4, 4/3] of the planned
  // count, a bound moved by more than a tenth of the planned extent on its
  // axis, or the boxes' typical extent (extent_floor) moved by more than a
  // factor of two. Returns whether it planned. Deterministic in (bounds,
  // extents, n, boxes_per_cell, shape).
  bool update(const Bounds& bounds, const ExtentHistogram& extents, std::uint32_t n, std::uint32_t boxes_per_cell,
              CellShape shape);
  // A frame of as many objects as the last one takes its grid from the last
  // frame's bounds and extents (remember), so the device need not wait for
  // its own before cutting cells: update() on those, `replanned` its result.
  // False (nothing done) for a first frame or a changed count: the caller
  // then calls update() with the frame's own. A grid one frame late is
  // still correct (the outer cells are unbounded); both launchers follow
  // this rule, so their frame-order lists stay identical.
  bool update_from_last(std::uint32_t n, std::uint32_t boxes_per_cell, CellShape shape, bool& replanned);
  // The frame's own bounds and extents, for the next frame (valid boxes only).
  void remember(const Bounds& bounds, const ExtentHistogram& extents, std::uint32_t n);
  // The planes of axis k start at plane_offset(k) in planes().
  std::uint32_t plane_offset(int k) const;
  const std::vector<float>& planes() const { return planes_; }
  const std::uint32_t* dims() const { return dims_; }
  std::uint32_t cells() const { return dims_[0] * dims_[1] * dims_[2]; }
  // The grid over `planes` (host or device copy of planes()).
  GridView view(const float* planes) const;

 private:
  void plan(const Bounds& bounds, const ExtentHistogram& extents, const std::uint32_t floor_bin[3], std::uint32_t n,
            std::uint32_t boxes_per_cell, CellShape shape);
  std::uint32_t dims_[3] = {1, 1, 1};
  std::vector<float> planes_;  // capacity for every axis at its limit: no allocation per plan
  Bounds planned_{};
  std::uint32_t planned_n_ = 0;
  std::uint32_t planned_floor_bin_[3] = {0, 0, 0};
  bool valid_ = false;
  Bounds last_bounds_{};
  ExtentHistogram last_extents_{};
  std::uint32_t last_n_ = 0;
  bool has_last_ = false;
};

}  // namespace hbp::cuda
