// SPDX-License-Identifier: MIT
#include "cuda/grid_plan.hpp"

#include <algorithm>
#include <cmath>

namespace hbp::cuda {

GridPlan::GridPlan() { planes_.reserve(3 * kMaxAxisCells); }

namespace {

// Boxes a cell should be at least as wide as, on each axis: all but this
// fraction (they may span more cells, or go to the large pass).
constexpr double kFloorQuantile = 0.99;

// The extent bin holding the kFloorQuantile-th box's extent on each axis.
void floor_bins(const ExtentHistogram& h, std::uint32_t n, std::uint32_t out[3]) {
  const auto need = static_cast<std::uint64_t>(kFloorQuantile * n);
  for (int k = 0; k < 3; ++k) {
    std::uint64_t seen = 0;
    out[k] = 0;
    for (std::uint32_t bin = 0; bin < kExtentBins; ++bin) {
      seen += h.count[k][bin];
      if (seen >= need) {
        out[k] = bin;
        break;
      }
    }
  }
}

// The largest extent in a bin: below 2^(bin - 126) (bin 255, infinite
// extents, gives no floor: such boxes go to the large pass).
double bin_ceiling(std::uint32_t bin) { return bin >= 255 ? 0.0 : std::ldexp(1.0, static_cast<int>(bin) - 126); }

// Columns (CellShape): y and z cut kColumnSection times more finely (in
// area) than the cubes, but never below the width of all but n /
// kColumnTail boxes: a box wider than its cell on two axes may meet more
// than kMaxRefsPerBox cells and go to the large pass, which tests it
// against every box, so the few wider boxes must stay few. x is cut for a
// kColumnSection-th of the cubes' count: every x cut replicates boxes and
// none shortens a row (the sweep stops on x by itself), so the columns
// hold kColumnSection times the boxes of a cube.
constexpr double kColumnSection = 4;
constexpr std::uint32_t kColumnTail = 4096;

// The extent below which all but n / kColumnTail boxes lie on axis k (a bin
// ceiling; boxes of infinite extent aside).
double tail_extent(const ExtentHistogram& h, std::uint32_t n, int k) {
  const std::uint64_t allowed = n / kColumnTail;
  std::uint64_t above = 0;
  for (std::uint32_t bin = kExtentBins - 2; bin > 0; --bin) {
    above += h.count[k][bin];
    if (above > allowed) return bin_ceiling(bin);
  }
  return bin_ceiling(0);
}

}  // namespace

bool GridPlan::update(const Bounds& b, const ExtentHistogram& extents, std::uint32_t n,
                      std::uint32_t boxes_per_cell, CellShape shape) {
  std::uint32_t floor_bin[3];
  floor_bins(extents, n, floor_bin);
  bool keep = valid_ && 4ull * n >= 3ull * planned_n_ && 3ull * n <= 4ull * planned_n_;
  for (int k = 0; keep && k < 3; ++k) {
    const double extent = static_cast<double>(planned_.hi[k]) - planned_.lo[k];
    const double slack = extent / 10;
    keep = std::fabs(static_cast<double>(b.lo[k]) - planned_.lo[k]) <= slack &&
           std::fabs(static_cast<double>(b.hi[k]) - planned_.hi[k]) <= slack &&
           floor_bin[k] + 1 >= planned_floor_bin_[k] && floor_bin[k] <= planned_floor_bin_[k] + 1;
  }
  if (keep) return false;
  plan(b, extents, floor_bin, n, boxes_per_cell, shape);
  return true;
}

bool GridPlan::update_from_last(std::uint32_t n, std::uint32_t boxes_per_cell, CellShape shape, bool& replanned) {
  if (!has_last_ || n != last_n_) return false;
  replanned = update(last_bounds_, last_extents_, n, boxes_per_cell, shape);
  return true;
}

void GridPlan::remember(const Bounds& bounds, const ExtentHistogram& extents, std::uint32_t n) {
  last_bounds_ = bounds;
  last_extents_ = extents;
  last_n_ = n;
  has_last_ = true;
}

void GridPlan::plan(const Bounds& b, const ExtentHistogram& extents, const std::uint32_t floor_bin[3],
                    std::uint32_t n, std::uint32_t boxes_per_cell, CellShape shape) {
  const double target = std::clamp(static_cast<double>(n) / boxes_per_cell, 1.0, static_cast<double>(kMaxCells));
  double extent[3], floor[3];
  bool active[3];
  for (int k = 0; k < 3; ++k) {
    extent[k] = static_cast<double>(b.hi[k]) - b.lo[k];
    floor[k] = bin_ceiling(floor_bin[k]);
    active[k] = extent[k] > 0;
  }
  // Cubic cells of the edge that gives `target` cells over the axes still
  // active; an axis whose extent is no more than two cells (its edge or its
  // floor) is not cut, and the edge is found again over the others, so a
  // flat scene gets a 2-D grid. Cells are never narrower than the floor, so
  // there are at most `target` of them.
  double edge = 1;
  for (bool changed = true; changed;) {
    changed = false;
    double volume = 1;
    int axes = 0;
    for (int k = 0; k < 3; ++k)
      if (active[k]) {
        volume *= extent[k];
        ++axes;
      }
    edge = axes ? std::pow(volume / target, 1.0 / axes) : 1.0;
    for (int k = 0; k < 3; ++k)
      if (active[k] && extent[k] < 2 * std::max(edge, floor[k])) {
        active[k] = false;
        changed = true;
      }
  }
  // Columns: a narrower edge on y and z when x and one of them are cut,
  // then x cut for the cell count (below).
  double cell[3] = {edge, edge, edge};
  const int sections = int(active[1]) + int(active[2]);
  const bool columns = shape == CellShape::Columns && active[0] && sections > 0;
  if (columns)
    for (int k = 1; k < 3; ++k)
      cell[k] = std::min(edge, std::max(edge / std::pow(kColumnSection, 1.0 / sections), tail_extent(extents, n, k)));
  const auto cells_on = [&](int k, double want) {
    // As many cells as asked (rounded up), but none narrower than the
    // floor (rounded down).
    const double d = active[k] ? std::min(std::ceil(want), std::floor(extent[k] / floor[k])) : 1.0;
    return static_cast<std::uint32_t>(std::clamp(d, 1.0, static_cast<double>(kMaxAxisCells)));
  };
  for (int k = 0; k < 3; ++k) dims_[k] = cells_on(k, extent[k] / cell[k]);
  if (columns) dims_[0] = cells_on(0, target / kColumnSection / (static_cast<double>(dims_[1]) * dims_[2]));
  while (std::uint64_t{dims_[0]} * dims_[1] * dims_[2] > kMaxCells) {
    std::uint32_t* largest = std::max_element(dims_, dims_ + 3);
    *largest = (*largest + 1) / 2;
  }
  planes_.clear();
  for (int k = 0; k < 3; ++k)
    for (std::uint32_t i = 1; i < dims_[k]; ++i)
      planes_.push_back(static_cast<float>(b.lo[k] + extent[k] * i / dims_[k]));
  planned_ = b;
  planned_n_ = n;
  for (int k = 0; k < 3; ++k) planned_floor_bin_[k] = floor_bin[k];
  valid_ = true;
}

std::uint32_t GridPlan::plane_offset(int k) const {
  std::uint32_t offset = 0;
  for (int a = 0; a < k; ++a) offset += dims_[a] - 1;
  return offset;
}

GridView GridPlan::view(const float* planes) const {
  GridView g{};
  for (int k = 0; k < 3; ++k) {
    g.dims[k] = dims_[k];
    g.planes[k] = planes + plane_offset(k);
  }
  g.x_lo = planned_.lo[0];
  g.x_hi = planned_.hi[0];
  return g;
}

}  // namespace hbp::cuda
