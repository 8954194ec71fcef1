// SPDX-License-Identifier: MIT
#include "cuda/grid_plan.hpp"

#include <algorithm>
#include <cmath>

namespace hbp::cuda {

GridPlan::GridPlan() { planes_.reserve(3 * kMaxAxisCells); }

bool GridPlan::update(const Bounds& b, std::uint32_t n, std::uint32_t boxes_per_cell) {
  bool keep = valid_ && 4ull * n >= 3ull * planned_n_ && 3ull * n <= 4ull * planned_n_;
  for (int k = 0; keep && k < 3; ++k) {
    const double extent = static_cast<double>(planned_.hi[k]) - planned_.lo[k];
    const double slack = extent / 10;
    keep = std::fabs(static_cast<double>(b.lo[k]) - planned_.lo[k]) <= slack &&
           std::fabs(static_cast<double>(b.hi[k]) - planned_.hi[k]) <= slack;
  }
  if (keep) return false;
  plan(b, n, boxes_per_cell);
  return true;
}

void GridPlan::plan(const Bounds& b, std::uint32_t n, std::uint32_t boxes_per_cell) {
  const double target = std::clamp(static_cast<double>(n) / boxes_per_cell, 1.0, static_cast<double>(kMaxCells));
  double extent[3];
  double volume = 1;
  int active = 0;
  for (int k = 0; k < 3; ++k) {
    extent[k] = static_cast<double>(b.hi[k]) - b.lo[k];
    if (extent[k] > 0) {
      volume *= extent[k];
      ++active;
    }
  }
  // Cubic cells of the edge that gives `target` cells over the extent of the
  // axes that have one (a flat scene gets a 2-D grid).
  const double edge = active ? std::pow(volume / target, 1.0 / active) : 1.0;
  for (int k = 0; k < 3; ++k) {
    const double d = extent[k] > 0 ? std::ceil(extent[k] / edge) : 1.0;
    dims_[k] = static_cast<std::uint32_t>(std::clamp(d, 1.0, static_cast<double>(kMaxAxisCells)));
  }
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
  return g;
}

}  // namespace hbp::cuda
