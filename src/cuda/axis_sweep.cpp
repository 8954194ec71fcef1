// SPDX-License-Identifier: MIT
// AxisSweep's facade and its CPU launcher: the sweep body of the frame
// (frame_bodies.hpp: sweep_row, over the whole scene as one cell whose
// region is everything) on lanes permuted so the sweep axis comes first.
#include "hbp/cuda/axis_sweep.hpp"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <utility>

#include "cuda/axis_sweep_impl.hpp"
#include "cuda/frame_bodies.hpp"
#include "cuda/frame_impl.hpp"
#include "cuda/host_blocks.hpp"
#include "cuda/host_radix.hpp"
#include "hbp/error.hpp"

namespace hbp::cuda {
namespace {

class HostAxisSweep final : public AxisSweep::Impl {
 public:
  using Impl::Impl;
  void run(const Lanes& in) override {
    using Clock = std::chrono::steady_clock;
    info = {};
    const auto t0 = Clock::now();
    const std::uint32_t n = in.n;
    double sum[3] = {0, 0, 0}, sum_sq[3] = {0, 0, 0};
    for (std::uint32_t i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        const double c = static_cast<double>(in.lo[k][i]) + in.hi[k][i];
        sum[k] += c;
        sum_sq[k] += c * c;
      }
    }
    axis = largest_variance_axis(sum, sum_sq, n);
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    keys_.resize(n);
    ids_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      keys_[i] = ordered_bits(in.lo[axis][i]);
      ids_[i] = i;
    }
    radix_sort(keys_, key_scratch_, &ids_, &id_scratch_, 32);
    const float* src[6] = {in.lo[axis], in.lo[a1], in.lo[a2], in.hi[axis], in.hi[a1], in.hi[a2]};
    for (int l = 0; l < 6; ++l) {
      lanes_[l].resize(n);
      for (std::uint32_t r = 0; r < n; ++r) lanes_[l][r] = src[l][ids_[r]];
    }
    const auto t1 = Clock::now();
    const SortedLanes s{{lanes_[0].data(), lanes_[1].data(), lanes_[2].data()},
                        {lanes_[3].data(), lanes_[4].data(), lanes_[5].data()},
                        ids_.data()};
    const CellRegion everything = CellRegion::everything();
    offsets_.resize(std::size_t{n} + 1);
    for_blocks(options.threads, n, [&](std::uint64_t r) {
      offsets_[r] = sweep_row(s, static_cast<std::uint32_t>(r), n, everything,
                              [](std::uint32_t, std::uint32_t, std::uint32_t) {});
    });
    std::uint64_t total = 0;
    for (std::uint32_t r = 0; r < n; ++r) total += std::exchange(offsets_[r], total);
    offsets_[n] = total;
    const auto t2 = Clock::now();
    if (options.max_pairs && total > options.max_pairs) throw_too_many_pairs(total, options.max_pairs);
    pairs.resize(total);
    for_blocks(options.threads, n, [&](std::uint64_t r) {
      Pair* row = pairs.data() + offsets_[r];
      sweep_row(s, static_cast<std::uint32_t>(r), n, everything,
                [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) { row[k] = make_pair(a, b); });
    });
    const auto t3 = Clock::now();
    if (options.sorted) std::sort(pairs.begin(), pairs.end());
    const auto t4 = Clock::now();
    auto ms = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
    info.pairs = total;
    info.times.sort_ms = ms(t0, t1);
    info.times.count_ms = ms(t1, t2);
    info.times.fill_ms = ms(t2, t3);
    info.times.order_ms = ms(t3, t4);
    info.times.frame_ms = ms(t0, t4);
  }

 private:
  std::vector<std::uint64_t> keys_, key_scratch_, offsets_;
  std::vector<std::uint32_t> ids_, id_scratch_;
  std::vector<float> lanes_[6];
};

}  // namespace

std::unique_ptr<AxisSweep::Impl> make_host_axis_sweep(const FrameOptions& options) {
  return std::make_unique<HostAxisSweep>(options);
}

AxisSweep::AxisSweep(const FrameOptions& options) {
  if (options.threads == 0) throw InvalidInput("FrameOptions::threads must be >= 1");
  impl_ = options.launcher == Launcher::Device ? make_device_axis_sweep(options) : make_host_axis_sweep(options);
}
AxisSweep::~AxisSweep() = default;
AxisSweep::AxisSweep(AxisSweep&&) noexcept = default;
AxisSweep& AxisSweep::operator=(AxisSweep&&) noexcept = default;

const std::vector<Pair>& AxisSweep::update(const Lanes& boxes) {
  check_host_lanes(boxes);  // host lanes on both launchers
  impl_->run(boxes);
  return impl_->pairs;
}
const FrameInfo& AxisSweep::info() const { return impl_->info; }
int AxisSweep::axis() const { return impl_->axis; }

}  // namespace hbp::cuda
