// SPDX-License-Identifier: MIT
#include "hbp/cuda/frame_broadphase.hpp"

#include <cstdint>
#include <string>

#include "cuda/frame_bodies.hpp"
#include "cuda/frame_impl.hpp"
#include "hbp/error.hpp"

namespace hbp::cuda {

DevicePairs FrameBroadPhase::Impl::run_device(const Lanes&, void*) {
  throw InvalidInput("FrameBroadPhase::update_device needs Launcher::Device");
}
DevicePairs FrameBroadPhase::Impl::run_device(const DeviceRows&, void*) {
  throw InvalidInput("FrameBroadPhase::update_device needs Launcher::Device");
}

const char* cell_shape_name(CellShape shape) { return shape == CellShape::Cubes ? "cubes" : "columns"; }

CellShape parse_cell_shape(const std::string& name) {
  for (const CellShape shape : {CellShape::Columns, CellShape::Cubes})
    if (name == cell_shape_name(shape)) return shape;
  throw InvalidInput("cell_shape: 'columns' or 'cubes', got '" + name + "'");
}

void check_object_count(std::uint32_t n) {
  if (n > kMaxFrameObjects)
    throw InvalidInput("FrameBroadPhase: " + std::to_string(n) + " objects, more than the limit " +
                       std::to_string(kMaxFrameObjects));
}

namespace {
// InvalidInput unless `data` can hold n floats a kernel reads: not null (for
// n > 0) and aligned to a float (a misaligned device read is a sticky error
// that ends the whole CUDA context, the caller's arrays with it).
void check_float_data(const float* data, std::uint32_t n, const std::string& what) {
  if (n && !data) throw InvalidInput(what + ": null data for " + std::to_string(n) + " objects");
  const auto address = reinterpret_cast<std::uintptr_t>(data);
  if (address % alignof(float) != 0)
    throw InvalidInput(what + ": data at address " + std::to_string(address) + " is not aligned to a float (" +
                       std::to_string(alignof(float)) + " bytes)");
}
}  // namespace

void check_host_lanes(const Lanes& boxes) {
  check_object_count(boxes.n);
  const BoxLanesView b{{boxes.lo[0], boxes.lo[1], boxes.lo[2]}, {boxes.hi[0], boxes.hi[1], boxes.hi[2]}};
  for (std::uint32_t i = 0; i < boxes.n; ++i)
    if (const std::uint32_t code = box_defect(b, i)) throw_box_defect(i, code);
}

void throw_box_defect(std::uint32_t i, std::uint32_t code) {
  static const char* const axes = "xyz";
  const char axis = axes[(code - 1) % 3];
  const std::string what = code <= 3 ? std::string(" has a NaN or infinite coordinate on ") + axis
                                     : std::string(" has min > max on ") + axis;
  throw InvalidInput("boxes: object " + std::to_string(i) + what);
}

void throw_too_many_pairs(std::uint64_t total, std::uint64_t max_pairs) {
  throw CapacityExceeded("frame has more than max_pairs = " + std::to_string(max_pairs) +
                         " overlapping pairs (counted " + std::to_string(total) + ")");
}

FrameBroadPhase::FrameBroadPhase(const FrameOptions& options) {
  if (options.threads == 0) throw InvalidInput("FrameOptions::threads must be >= 1");
  if (options.boxes_per_cell == 0) throw InvalidInput("FrameOptions::boxes_per_cell must be >= 1");
  if (options.pair_write == PairWrite::Append && (!options.sorted || options.sweep != CellSweep::PerReference))
    throw InvalidInput("FrameOptions::pair_write Append needs sorted pairs and CellSweep::PerReference "
                       "(appended pairs come in no fixed order)");
  impl_ = options.launcher == Launcher::Device ? make_device_frame(options) : make_host_frame(options);
}
FrameBroadPhase::~FrameBroadPhase() = default;
FrameBroadPhase::FrameBroadPhase(FrameBroadPhase&&) noexcept = default;
FrameBroadPhase& FrameBroadPhase::operator=(FrameBroadPhase&&) noexcept = default;

const std::vector<Pair>& FrameBroadPhase::update(const Lanes& boxes) {
  check_object_count(boxes.n);
  impl_->run(boxes);
  return impl_->pairs;
}

void FrameBroadPhase::reserve(std::uint32_t objects) {
  check_object_count(objects);
  impl_->reserve(objects);
}

DevicePairs FrameBroadPhase::update_device(const Lanes& device_boxes, void* stream) {
  check_object_count(device_boxes.n);
  static const char* const kLaneNames[6] = {"min x", "min y", "min z", "max x", "max y", "max z"};
  for (int l = 0; l < 6; ++l)
    check_float_data(l < 3 ? device_boxes.lo[l] : device_boxes.hi[l - 3], device_boxes.n,
                     std::string("device lanes: ") + kLaneNames[l]);
  return impl_->run_device(device_boxes, stream);
}

DevicePairs FrameBroadPhase::update_device(const DeviceRows& device_boxes, void* stream) {
  check_device_rows(device_boxes);
  return impl_->run_device(device_boxes, stream);
}

void check_device_rows(const DeviceRows& rows) {
  check_object_count(rows.n);
  check_float_data(rows.data, rows.n, "DeviceRows");
}

const std::vector<Pair>& FrameBroadPhase::pairs() const { return impl_->pairs; }
const FrameInfo& FrameBroadPhase::info() const { return impl_->info; }
const FrameOptions& FrameBroadPhase::options() const { return impl_->options; }

}  // namespace hbp::cuda
