// SPDX-License-Identifier: MIT
#pragma once
// The launchers of Lbvh share this base.
#include <memory>
#include <vector>

#include "hbp/cuda/lbvh.hpp"

namespace hbp::cuda {

struct Lbvh::Impl {
  explicit Impl(const FrameOptions& o) : options(o) {}
  virtual ~Impl() = default;
  virtual void run(const Lanes& boxes) = 0;
  FrameOptions options;
  FrameInfo info;
  std::vector<Pair> pairs;
};

std::unique_ptr<Lbvh::Impl> make_host_lbvh(const FrameOptions& options);
std::unique_ptr<Lbvh::Impl> make_device_lbvh(const FrameOptions& options);

}  // namespace hbp::cuda
