// SPDX-License-Identifier: MIT
#include "baselines/reported_pairs.hpp"

#include <algorithm>
#include <string>

#include "hbp/error.hpp"

namespace hbp::baselines {

const std::vector<Pair>& ReportedPairs::exact() {
  if (dirty_ && boxes_) {
    exact_.clear();
    for (const Pair& p : raw_)
      if (p.a != p.b && overlaps(boxes_->get(p.a), boxes_->get(p.b))) exact_.push_back(make_pair(p.a, p.b));
    canonicalize(exact_);
    dirty_ = false;
  }
  return exact_;
}

void ReportedPairs::clear() {
  raw_.clear();
  exact_.clear();
  boxes_ = nullptr;
  dirty_ = false;
}

void ReportingBaseline::update(const BoxArray& boxes) {
  const std::size_t n = object_count();
  if (boxes.size() != n)
    throw InvalidInput(name() + ": frame has " + std::to_string(boxes.size()) + " boxes, setup had " +
                       std::to_string(n));
  move_objects(boxes);
  collide(boxes);
}

Aabb box_bounds(const BoxArray& boxes) {
  Aabb w{{0, 0, 0}, {1, 1, 1}};
  if (boxes.empty()) return w;
  for (int k = 0; k < 3; ++k) {
    const float* lo = boxes.min(k);
    const float* hi = boxes.max(k);
    w.min[k] = *std::min_element(lo, lo + boxes.size());
    w.max[k] = *std::max_element(hi, hi + boxes.size());
  }
  return w;
}

Aabb grown_bounds(const BoxArray& boxes) {
  Aabb w = box_bounds(boxes);
  if (boxes.empty()) return w;
  for (int k = 0; k < 3; ++k) {
    const float grow = std::max(1.0f, 0.25f * (w.max[k] - w.min[k]));
    w.min[k] -= grow;
    w.max[k] += grow;
  }
  return w;
}

double mean_largest_extent(const BoxArray& boxes) {
  if (boxes.empty()) return 1;
  double sum = 0;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    float e = 0;
    for (int k = 0; k < 3; ++k) e = std::max(e, boxes.max(k)[i] - boxes.min(k)[i]);
    sum += e;
  }
  const double mean = sum / static_cast<double>(boxes.size());
  return mean > 0 ? mean : 1;
}

}  // namespace hbp::baselines
