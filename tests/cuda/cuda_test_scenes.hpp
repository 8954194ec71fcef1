// SPDX-License-Identifier: MIT
#pragma once
// Scenes for the GPU room's tests: every scenario kind and the adversarial
// ones, as BoxArrays, and their lanes for hbp::cuda::FrameBroadPhase.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cuda/frame_broadphase.hpp"
#include "hbp/error.hpp"
#include "hbp/pair.hpp"
#include "hbp/scenario.hpp"

namespace hbp::cuda_test {

using cuda::lanes_of;

// A few frames of a scenario kind.
inline std::vector<BoxArray> scenario_frames(ScenarioKind kind, std::uint32_t n, int frames) {
  ScenarioParams p;
  p.kind = kind;
  p.n = n;
  Scenario s(p);
  std::vector<BoxArray> out(frames);
  for (int f = 0; f < frames; ++f) {
    s.compute_boxes(out[f]);
    s.step();
  }
  return out;
}

inline BoxArray all_on_one_point(std::uint32_t n) {
  BoxArray b(n);
  for (std::uint32_t i = 0; i < n; ++i) b.set(i, Aabb{{1, 2, 3}, {1, 2, 3}});
  return b;
}

// Every box spans the world (large on any grid), plus small ones inside.
inline BoxArray spanning_world(std::uint32_t big, std::uint32_t small) {
  BoxArray b(big + small);
  for (std::uint32_t i = 0; i < big; ++i)
    b.set(i, Aabb{{-1000.0f - i, -1000, -1000}, {1000.0f + i, 1000, 1000}});
  for (std::uint32_t i = 0; i < small; ++i) {
    const float x = static_cast<float>(i % 37) * 50 - 900, y = static_cast<float>(i % 29) * 60 - 900;
    const float z = static_cast<float>(i % 23) * 70 - 800;
    b.set(big + i, Aabb{{x, y, z}, {x + 40, y + 40, z + 40}});
  }
  return b;
}

// Boxes at the ends of the float range among small ones: some span
// [-FLT_MAX, FLT_MAX] or [-1e30, 1e30] on every axis, some fill a corner up
// to +-FLT_MAX, some are points or flat boxes at +-FLT_MAX. Centres and
// extents then overflow a naive quantisation.
inline BoxArray extreme_boxes(std::uint32_t small) {
  const float m = std::numeric_limits<float>::max(), h = m / 2;
  const Aabb big[] = {
      {{-m, -m, -m}, {m, m, m}},       {{-m, -m, -m}, {m, m, m}},       {{-1e30f, -1e30f, -1e30f}, {1e30f, 1e30f, 1e30f}},
      {{-1e30f, -5, -5}, {1e30f, 5, 5}}, {{h, h, h}, {m, m, m}},         {{-m, -m, -m}, {-h, -h, -h}},
      {{m, m, m}, {m, m, m}},          {{m, m, m}, {m, m, m}},          {{-m, 0, 0}, {-m, 1, 1}},
      {{-m, -m, 0}, {m, m, 0}},        {{0, -m, 0}, {0, m, 0}},         {{-1e30f, -1e30f, 1e30f}, {-1e30f, -1e30f, 1e30f}}};
  const auto count = static_cast<std::uint32_t>(sizeof big / sizeof big[0]);
  BoxArray b(count + small);
  for (std::uint32_t i = 0; i < count; ++i) b.set(i, big[i]);
  for (std::uint32_t i = 0; i < small; ++i) {
    const float x = static_cast<float>(i % 31) * 3 - 45, y = static_cast<float>(i % 17) * 4 - 30;
    const float z = static_cast<float>(i % 13) * 5 - 30;
    b.set(count + i, Aabb{{x, y, z}, {x + 4, y + 4, z + 4}});
  }
  return b;
}

// n unit cubes scattered through [0, side)^3, every `every`-th of them
// `wide` units wide on y and z instead: a thin tail of wider boxes.
inline BoxArray wide_tail(std::uint32_t n, float side, std::uint32_t every, float wide) {
  BoxArray b(n);
  std::uint32_t state = 12345;
  const auto next = [&state, side] {
    state = state * 1664525u + 1013904223u;
    return static_cast<float>(state >> 8) / 16777216.0f * side;
  };
  for (std::uint32_t i = 0; i < n; ++i) {
    const float x = next(), y = next(), z = next(), w = i % every == 0 ? wide : 1.0f;
    b.set(i, Aabb{{x, y, z}, {x + 1, y + w, z + w}});
  }
  return b;
}

// The plain all-pairs oracle, for builds without the core library.
inline std::vector<Pair> all_pairs(const BoxArray& b) {
  std::vector<Pair> out;
  const auto n = static_cast<std::uint32_t>(b.size());
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j) {
      bool hit = true;
      for (int k = 0; k < 3; ++k) hit = hit && b.max(k)[i] >= b.min(k)[j] && b.min(k)[i] <= b.max(k)[j];
      if (hit) out.push_back(Pair{i, j});
    }
  return out;
}

// The CapacityExceeded message of a frame or peer run on `boxes`; "" when it
// is not thrown.
template <class Frame>
std::string capacity_message(Frame& f, const BoxArray& boxes) {
  try {
    f.update(lanes_of(boxes));
  } catch (const CapacityExceeded& e) {
    return e.what();
  }
  return "";
}

// The one-point scene's pairs (every i < j, sorted) for `n` objects on one
// point, checked without building the list: at 14,143 objects it holds
// 100,005,153 pairs (800 MB). Returns the first index that differs, or
// pairs.size() when they are all there, in order.
inline std::size_t first_pair_not_all_of(const std::vector<Pair>& pairs, std::uint32_t n) {
  std::size_t k = 0;
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j, ++k)
      if (k == pairs.size() || pairs[k].a != i || pairs[k].b != j) return k;
  return k;
}

// Objects on one point giving just over 10^8 pairs: 14,143 * 14,142 / 2.
inline constexpr std::uint32_t kHundredMillionPairsOnOnePoint = 14'143;
inline constexpr std::uint64_t kHundredMillionPairs = 100'005'153;
static_assert(std::uint64_t{kHundredMillionPairsOnOnePoint} * (kHundredMillionPairsOnOnePoint - 1) / 2 ==
              kHundredMillionPairs);

}  // namespace hbp::cuda_test
