// SPDX-License-Identifier: MIT
// Lbvh's facade and its CPU launcher: the bodies of lbvh_bodies.hpp run
// stage by stage as lbvh_device.cu runs them, blocks spread over
// FrameOptions::threads CPU threads. Buffers are members kept across frames
// under the retained rule (support/retained.hpp): a steady frame allocates
// nothing.
#include "hbp/cuda/lbvh.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <utility>
#include <vector>

#include "cuda/frame_bodies.hpp"
#include "cuda/frame_impl.hpp"
#include "cuda/host_blocks.hpp"
#include "cuda/host_radix.hpp"
#include "cuda/lbvh_bodies.hpp"
#include "cuda/lbvh_impl.hpp"
#include "hbp/error.hpp"
#include "support/retained.hpp"

namespace hbp::cuda {
namespace {

class HostLbvh final : public Lbvh::Impl {
 public:
  using Impl::Impl;
  void run(const Lanes& in) override {
    using Clock = std::chrono::steady_clock;
    info = {};
    const std::uint32_t n = in.n;
    const unsigned threads = options.threads;
    const BoxLanesView b{{in.lo[0], in.lo[1], in.lo[2]}, {in.hi[0], in.hi[1], in.hi[2]}};
    const auto t0 = Clock::now();

    // Bounds as ordered bits (launch_bounds' layout and arithmetic):
    // per-slice folds, then the slices folded; min/max, so exact.
    constexpr std::uint32_t kSlices = 64;
    std::uint32_t part[kSlices][6];
    for_blocks(threads, kSlices, [&](std::uint64_t s) {
      std::uint32_t* p = part[s];
      p[0] = p[1] = p[2] = ~0u;
      p[3] = p[4] = p[5] = 0;
      const auto lo = static_cast<std::uint32_t>(n * s / kSlices), hi = static_cast<std::uint32_t>(n * (s + 1) / kSlices);
      for (std::uint32_t i = lo; i < hi; ++i)
        for (int k = 0; k < 3; ++k) {
          p[k] = std::min(p[k], ordered_bits(b.lo[k][i]));
          p[3 + k] = std::max(p[3 + k], ordered_bits(b.hi[k][i]));
        }
    });
    std::uint32_t bounds[6] = {~0u, ~0u, ~0u, 0, 0, 0};
    for (const auto& p : part)
      for (int k = 0; k < 3; ++k) {
        bounds[k] = std::min(bounds[k], p[k]);
        bounds[3 + k] = std::max(bounds[3 + k], p[3 + k]);
      }
    const auto t1 = Clock::now();

    // Morton keys over indices, sorted; the boxes gathered in that order.
    grow(keys_, n);
    grow(key_scratch_, n);  // the sort's room, grown with keys_: it never allocates
    for_blocks(threads, n, [&](std::uint64_t i) { keys_[i] = morton_key(bounds, b, static_cast<std::uint32_t>(i)); });
    radix_sort(keys_, key_scratch_, nullptr, nullptr, 64);
    grow(ids_, n);
    for (auto& lane : lanes_) grow(lane, n);
    for_blocks(threads, n, [&](std::uint64_t r) {
      const auto i = static_cast<std::uint32_t>(keys_[r]);
      ids_[r] = i;
      for (int k = 0; k < 3; ++k) {
        lanes_[k][r] = b.lo[k][i];
        lanes_[3 + k][r] = b.hi[k][i];
      }
    });
    const SortedLanes leaves{{lanes_[0].data(), lanes_[1].data(), lanes_[2].data()},
                             {lanes_[3].data(), lanes_[4].data(), lanes_[5].data()},
                             ids_.data()};
    const auto t2 = Clock::now();

    // The radix tree, then its bounds bottom-up.
    const std::uint32_t nodes = n ? n - 1 : 0;
    for (auto* v : {&left_, &right_, &last_, &node_parent_, &visits_}) grow(*v, nodes);
    grow(leaf_parent_, n);
    for (auto& lane : node_lanes_) grow(lane, nodes);
    const LbvhNodes tree{left_.data(),
                         right_.data(),
                         last_.data(),
                         node_parent_.data(),
                         leaf_parent_.data(),
                         {node_lanes_[0].data(), node_lanes_[1].data(), node_lanes_[2].data()},
                         {node_lanes_[3].data(), node_lanes_[4].data(), node_lanes_[5].data()}};
    for_blocks(threads, nodes, [&](std::uint64_t i) { build_node(keys_.data(), n, static_cast<std::uint32_t>(i), tree); });
    if (n >= 2) {
      std::fill(visits_.begin(), visits_.end(), 0u);
      // The first thread at a node leaves; the second (which sees the first's
      // writes through the acquire-release count) computes it.
      for_blocks(threads, n, [&](std::uint64_t q) {
        refit_from_leaf(leaves, tree, static_cast<std::uint32_t>(q), [this](std::uint32_t node) {
          return std::atomic_ref<std::uint32_t>(visits_[node]).fetch_add(1, std::memory_order_acq_rel) == 1;
        });
      });
    }
    const auto t3 = Clock::now();

    // Count, scan, max_pairs, fill: a leaf's pairs from its offset.
    grow(offsets_, std::size_t{n} + 1);
    for_blocks(threads, n, [&](std::uint64_t p) {
      offsets_[p] = lbvh_row(leaves, tree, n, static_cast<std::uint32_t>(p),
                             [](std::uint32_t, std::uint32_t, std::uint32_t) {});
    });
    std::uint64_t total = 0;
    for (std::uint32_t p = 0; p < n; ++p) total += std::exchange(offsets_[p], total);
    offsets_[n] = total;
    const auto t4 = Clock::now();
    if (options.max_pairs && total > options.max_pairs) throw_too_many_pairs(total, options.max_pairs);
    grow(pairs, total);
    for_blocks(threads, n, [&](std::uint64_t p) {
      Pair* row = pairs.data() + offsets_[p];
      lbvh_row(leaves, tree, n, static_cast<std::uint32_t>(p),
               [row](std::uint32_t k, std::uint32_t a, std::uint32_t bb) { row[k] = make_pair(a, bb); });
    });
    const auto t5 = Clock::now();
    if (options.sorted) std::sort(pairs.begin(), pairs.end());
    const auto t6 = Clock::now();

    auto ms = [](Clock::time_point a, Clock::time_point c) { return std::chrono::duration<double, std::milli>(c - a).count(); };
    info.pairs = total;
    info.times.bounds_ms = ms(t0, t1);
    info.times.sort_ms = ms(t1, t2);
    info.times.refs_ms = ms(t2, t3);
    info.times.count_ms = ms(t3, t4);
    info.times.fill_ms = ms(t4, t5);
    info.times.order_ms = ms(t5, t6);
    info.times.frame_ms = ms(t0, t6);
    info.buffer_bytes = bytes();
  }

 private:
  // Resizes a kept buffer to n elements: storage far beyond n is given back
  // first (the retained rule), a growth reserves an eighth more so the pair
  // count's frame-to-frame jitter does not reallocate, and each growth is
  // counted in info.allocations.
  template <class V>
  void grow(V& v, std::size_t n) {
    retained::release(v, n);
    if (n > v.capacity()) {
      ++info.allocations;
      v.reserve(n + n / 8 + 64);
    }
    v.resize(n);
  }
  std::uint64_t bytes() const {
    std::uint64_t sum = 0;
    auto add = [&](const auto& v) { sum += v.capacity() * sizeof(v[0]); };
    add(keys_), add(key_scratch_), add(offsets_), add(ids_), add(left_), add(right_), add(last_);
    add(node_parent_), add(leaf_parent_), add(visits_), add(pairs);
    for (const auto& lane : lanes_) add(lane);
    for (const auto& lane : node_lanes_) add(lane);
    return sum;
  }

  std::vector<std::uint64_t> keys_, key_scratch_, offsets_;
  std::vector<std::uint32_t> ids_, left_, right_, last_, node_parent_, leaf_parent_, visits_;
  std::vector<float> lanes_[6], node_lanes_[6];  // sorted boxes; internal nodes' bounds (lo x, y, z, hi x, y, z)
};

}  // namespace

std::unique_ptr<Lbvh::Impl> make_host_lbvh(const FrameOptions& options) { return std::make_unique<HostLbvh>(options); }

Lbvh::Lbvh(const FrameOptions& options) {
  if (options.threads == 0) throw InvalidInput("FrameOptions::threads must be >= 1");
  impl_ = options.launcher == Launcher::Device ? make_device_lbvh(options) : make_host_lbvh(options);
}
Lbvh::~Lbvh() = default;
Lbvh::Lbvh(Lbvh&&) noexcept = default;
Lbvh& Lbvh::operator=(Lbvh&&) noexcept = default;

const std::vector<Pair>& Lbvh::update(const Lanes& boxes) {
  check_host_lanes(boxes);  // host lanes on both launchers
  impl_->run(boxes);
  return impl_->pairs;
}
const FrameInfo& Lbvh::info() const { return impl_->info; }

}  // namespace hbp::cuda
