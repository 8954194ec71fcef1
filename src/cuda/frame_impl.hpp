// SPDX-License-Identifier: MIT
#pragma once
// What the launchers of FrameBroadPhase share: the implementation's base
// (options, last frame's pairs and info) and the errors they raise, worded
// as the CPU path words them.
#include <cstdint>
#include <memory>
#include <vector>

#include "hbp/cuda/frame_broadphase.hpp"

namespace hbp::cuda {

struct FrameBroadPhase::Impl {
  explicit Impl(const FrameOptions& o) : options(o) {}
  virtual ~Impl() = default;
  // Runs a frame over host lanes: fills `pairs` and `info`.
  virtual void run(const Lanes& boxes) = 0;
  // Runs a frame over device lanes (device launcher only).
  virtual DevicePairs run_device(const Lanes& boxes, void* stream);
  virtual DevicePairs run_device(const DeviceRows& boxes, void* stream);
  // FrameBroadPhase::reserve.
  virtual void reserve(std::uint32_t objects) = 0;

  FrameOptions options;
  FrameInfo info;
  std::vector<Pair> pairs;
};

std::unique_ptr<FrameBroadPhase::Impl> make_host_frame(const FrameOptions& options);
// Throws hbp::Error "no CUDA device found" when there is none.
std::unique_ptr<FrameBroadPhase::Impl> make_device_frame(const FrameOptions& options);

// InvalidInput for more than kMaxFrameObjects objects.
void check_object_count(std::uint32_t n);
// The peers' check of host lanes before either launcher runs (the frame
// validates in its bounds pass instead): the object count, then the first
// defective box named (box_defect), as the CPU path does.
void check_host_lanes(const Lanes& boxes);
// InvalidInput naming object i and its defect (box_defect's code).
[[noreturn]] void throw_box_defect(std::uint32_t i, std::uint32_t code);
// CapacityExceeded: the frame has `total` pairs, more than max_pairs.
[[noreturn]] void throw_too_many_pairs(std::uint64_t total, std::uint64_t max_pairs);

}  // namespace hbp::cuda
