// SPDX-License-Identifier: MIT
#include "hbp/box_array.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <string>

#include "geometry/box_screen.hpp"
#include "hbp/error.hpp"

namespace hbp {

const char* box_defect(const Aabb& box) {
  for (int k = 0; k < 3; ++k) {
    if (std::isnan(box.min[k]) || std::isnan(box.max[k])) return "NaN coordinate";
    if (std::isinf(box.min[k]) || std::isinf(box.max[k])) return "infinite coordinate";
    if (box.min[k] > box.max[k]) return "min > max";
  }
  return nullptr;
}

void BoxArray::AlignedFree::operator()(float* p) const { std::free(p); }

BoxArray::BoxArray(const BoxArray& other) { *this = other; }

BoxArray& BoxArray::operator=(const BoxArray& other) {
  if (this == &other) return *this;
  resize(other.size_);
  for (int l = 0; l < 6; ++l) {
    if (size_ != 0) std::memcpy(lane(l), other.lane(l), size_ * sizeof(float));
  }
  return *this;
}

void BoxArray::pad_from(std::size_t first) {
  const float inf = std::numeric_limits<float>::infinity();
  for (int l = 0; l < 6; ++l) {
    float* p = lane(l);
    const float v = l < 3 ? inf : -inf;
    for (std::size_t i = first; i < capacity_; ++i) p[i] = v;
  }
}

void BoxArray::reserve(std::size_t n) {
  // Always keep a whole padding vector after the last box: a SIMD load that
  // starts at any index <= n stays inside the lane.
  const std::size_t want = ((n + kPadFloats - 1) / kPadFloats + 1) * kPadFloats;
  if (want <= capacity_) return;
  std::size_t cap = capacity_ == 0 ? want : capacity_;
  while (cap < want) cap *= 2;
  const std::size_t bytes = cap * 6 * sizeof(float);
  auto* raw = static_cast<float*>(std::aligned_alloc(kAlignment, bytes));
  if (raw == nullptr) throw std::bad_alloc();
  std::unique_ptr<float[], AlignedFree> fresh(raw);
  for (int l = 0; l < 6; ++l) {
    if (size_ != 0) std::memcpy(raw + l * cap, lane(l), size_ * sizeof(float));
  }
  data_ = std::move(fresh);
  capacity_ = cap;
  pad_from(size_);
}

void BoxArray::resize(std::size_t n) {
  reserve(n);
  if (n < size_) {
    const std::size_t old = size_;
    size_ = n;
    // Restore the padding invariant over the boxes that were dropped.
    const float inf = std::numeric_limits<float>::infinity();
    for (int l = 0; l < 6; ++l) {
      float* p = lane(l);
      for (std::size_t i = n; i < old; ++i) p[i] = l < 3 ? inf : -inf;
    }
  }
  size_ = n;
}

void BoxArray::push_back(const Aabb& box) {
  resize(size_ + 1);
  set(size_ - 1, box);
}

void BoxArray::validate(const char* what) const {
  for (std::size_t i = 0; i < size_; ++i) {
    const Aabb b = get(i);
    if (const char* defect = box_defect(b)) {
      const char* axis = "xyz";
      int k = 0;
      while (k < 3 && !geometry::interval_fails(b.min[k], b.max[k])) ++k;
      throw InvalidInput(std::string(what) + ": object " + std::to_string(i) + ": " + defect +
                         " on axis " + axis[k < 3 ? k : 0] + " (min " + std::to_string(b.min[k < 3 ? k : 0]) +
                         ", max " + std::to_string(b.max[k < 3 ? k : 0]) + ")");
    }
  }
}

}  // namespace hbp
