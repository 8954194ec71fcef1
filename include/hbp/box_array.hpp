// SPDX-License-Identifier: MIT
#pragma once
// Structure-of-arrays box container shared by every engine. Six float lanes
// (min x/y/z, max x/y/z), each 64-byte aligned and padded to a multiple of 16
// floats with boxes that overlap nothing (min = +inf, max = -inf), so SIMD
// kernels may read whole vectors past size() without a scalar tail.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>

#include "hbp/aabb.hpp"

namespace hbp {

class BoxArray {
 public:
  static constexpr std::size_t kAlignment = 64;
  static constexpr std::size_t kPadFloats = 16;

  BoxArray() = default;
  explicit BoxArray(std::size_t n) { resize(n); }
  BoxArray(const BoxArray& other);
  BoxArray& operator=(const BoxArray& other);
  // A moved-from array is empty and reusable (the defaulted moves left its
  // size and capacity pointing at storage it no longer owned).
  BoxArray(BoxArray&& other) noexcept
      : data_(std::move(other.data_)),
        size_(std::exchange(other.size_, 0)),
        capacity_(std::exchange(other.capacity_, 0)) {}
  BoxArray& operator=(BoxArray&& other) noexcept {
    data_ = std::move(other.data_);
    size_ = std::exchange(other.size_, 0);
    capacity_ = std::exchange(other.capacity_, 0);
    return *this;
  }

  // Keeps existing boxes; new ones are the never-overlapping padding box.
  // Never shrinks the allocation, so a per-frame resize does not allocate.
  void resize(std::size_t n);
  void reserve(std::size_t n);
  void clear() { resize(0); }
  void push_back(const Aabb& box);

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  std::size_t capacity() const { return capacity_; }

  float* min(int axis) { return lane(axis); }
  float* max(int axis) { return lane(3 + axis); }
  const float* min(int axis) const { return lane(axis); }
  const float* max(int axis) const { return lane(3 + axis); }

  Aabb get(std::size_t i) const {
    return {{min(0)[i], min(1)[i], min(2)[i]}, {max(0)[i], max(1)[i], max(2)[i]}};
  }
  void set(std::size_t i, const Aabb& b) {
    for (int k = 0; k < 3; ++k) {
      min(k)[i] = b.min[k];
      max(k)[i] = b.max[k];
    }
  }

  // Throws InvalidInput naming the first bad object (index, axis, defect).
  // `what` prefixes the message, e.g. "scene.bin frame 3".
  void validate(const char* what = "boxes") const;

 private:
  struct AlignedFree {
    void operator()(float* p) const;
  };
  float* lane(int l) { return data_.get() + static_cast<std::size_t>(l) * capacity_; }
  const float* lane(int l) const {
    return data_.get() + static_cast<std::size_t>(l) * capacity_;
  }
  void pad_from(std::size_t first);

  std::unique_ptr<float[], AlignedFree> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;  // per lane, multiple of kPadFloats, > size_
};

}  // namespace hbp
