// SPDX-License-Identifier: MIT
#include "pipeline/fat_moving_pairs.hpp"

#include <algorithm>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "hbp/error.hpp"
#include "support/retained.hpp"

namespace hbp::detail {

namespace {

bool overlap_at(const BoxArray& b, std::uint32_t i, std::uint32_t j) {
  return (b.min(0)[i] <= b.max(0)[j]) & (b.min(0)[j] <= b.max(0)[i]) & (b.min(1)[i] <= b.max(1)[j]) &
         (b.min(1)[j] <= b.max(1)[i]) & (b.min(2)[i] <= b.max(2)[j]) & (b.min(2)[j] <= b.max(2)[i]);
}

}  // namespace

Aabb fat_box(const Aabb& b) {
  constexpr float big = std::numeric_limits<float>::max();
  const float side = std::max({b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]});
  const float m = 0.5f * side;
  Aabb f;
  for (int k = 0; k < 3; ++k) {
    f.min[k] = std::max(b.min[k] - m, -big);
    f.max[k] = std::min(b.max[k] + m, big);
  }
  return f;
}

bool FatMovingPairs::find(const BoxArray& boxes, HybridBroadPhase& hybrid, std::size_t max_pairs,
                          std::vector<Pair>& out) {
  const std::size_t n = boxes.size();
  if (n > kMaxObjects || n < 2) {
    valid_ = false;
    return false;
  }
  if (cooldown_) {
    --cooldown_;
    valid_ = false;
    return false;
  }
  if (!valid_ || fat_.size() != n) {
    if (!rebuild(boxes, hybrid)) return false;
    last_rebuilt_ = false;
  } else {
    // The objects whose box left its fat box (a few in a thousand a frame).
    left_.clear();
    const float *x0 = boxes.min(0), *y0 = boxes.min(1), *z0 = boxes.min(2);
    const float *x1 = boxes.max(0), *y1 = boxes.max(1), *z1 = boxes.max(2);
    const float *fx0 = fat_.min(0), *fy0 = fat_.min(1), *fz0 = fat_.min(2);
    const float *fx1 = fat_.max(0), *fy1 = fat_.max(1), *fz1 = fat_.max(2);
    std::uint32_t d = 0;
#if defined(__SSE2__)
    for (; d + 4 <= n; d += 4) {
      __m128 in = _mm_and_ps(_mm_cmpge_ps(_mm_loadu_ps(x0 + d), _mm_loadu_ps(fx0 + d)),
                             _mm_cmpge_ps(_mm_loadu_ps(y0 + d), _mm_loadu_ps(fy0 + d)));
      in = _mm_and_ps(in, _mm_cmpge_ps(_mm_loadu_ps(z0 + d), _mm_loadu_ps(fz0 + d)));
      in = _mm_and_ps(in, _mm_cmple_ps(_mm_loadu_ps(x1 + d), _mm_loadu_ps(fx1 + d)));
      in = _mm_and_ps(in, _mm_cmple_ps(_mm_loadu_ps(y1 + d), _mm_loadu_ps(fy1 + d)));
      in = _mm_and_ps(in, _mm_cmple_ps(_mm_loadu_ps(z1 + d), _mm_loadu_ps(fz1 + d)));
      for (unsigned out = ~static_cast<unsigned>(_mm_movemask_ps(in)) & 15u; out; out &= out - 1)
        left_.push_back(d + static_cast<std::uint32_t>(__builtin_ctz(out)));
    }
#endif
    for (; d < n; ++d) {
      const bool in = (x0[d] >= fx0[d]) & (y0[d] >= fy0[d]) & (z0[d] >= fz0[d]) & (x1[d] <= fx1[d]) &
                      (y1[d] <= fy1[d]) & (z1[d] <= fz1[d]);
      if (!in) left_.push_back(d);
    }
    if (left_.size() * n > kMaxRetests) {
      // Two such frames in a row: the world is not mostly quiet now.
      if (last_rebuilt_) {
        give_up();
        return false;
      }
      if (!rebuild(boxes, hybrid)) return false;
      last_rebuilt_ = true;
    } else {
      last_rebuilt_ = false;
      if (!left_.empty()) {
        retest_left(boxes);
        if (cand_.size() > kMaxCandidatesPerObject * n) {  // the moving objects crowd together
          give_up();
          return false;
        }
      }
    }
  }
  next_cooldown_ = kCooldownFrames;  // the fat path works this frame
  // Every overlapping pair is a candidate: test them exactly (branch-free).
  out.resize(cand_.size());
  std::size_t k = 0;
  for (const Pair p : cand_) {
    out[k] = p;
    k += overlap_at(boxes, p.a, p.b);
  }
  out.resize(k);
  if (max_pairs && k > max_pairs)
    throw CapacityExceeded("frame has " + std::to_string(k) + " overlapping pairs, above max_pairs = " +
                           std::to_string(max_pairs));
  return true;
}

bool FatMovingPairs::rebuild(const BoxArray& boxes, HybridBroadPhase& hybrid) {
  const std::size_t n = boxes.size();
  fat_.resize(n);
  for (std::size_t d = 0; d < n; ++d) fat_.set(d, fat_box(boxes.get(d)));
  const std::vector<Pair>* raw = nullptr;
  try {
    raw = &hybrid.update(fat_);
  } catch (const CapacityExceeded&) {
    raw = nullptr;  // more fat pairs than max_pairs: the exact boxes decide
  }
  if (!raw || raw->size() > kMaxCandidatesPerObject * n) {
    give_up();
    return false;
  }
  cand_.assign(raw->begin(), raw->end());
  retained::trim(cand_);
  valid_ = true;
  return true;
}

// New fat boxes for the objects in left_, whose candidates are found again
// against every fat box (a pair of two such objects is found once, from its
// smaller index).
void FatMovingPairs::retest_left(const BoxArray& boxes) {
  const std::uint32_t n = static_cast<std::uint32_t>(boxes.size());
  is_left_.resize(n, 0);
  for (const std::uint32_t r : left_) {
    fat_.set(r, fat_box(boxes.get(r)));
    is_left_[r] = 1;
  }
  cand_.erase(std::remove_if(cand_.begin(), cand_.end(), [&](Pair p) { return is_left_[p.a] | is_left_[p.b]; }),
              cand_.end());
  fresh_.clear();
  const float *x0 = fat_.min(0), *y0 = fat_.min(1), *z0 = fat_.min(2);
  const float *x1 = fat_.max(0), *y1 = fat_.max(1), *z1 = fat_.max(2);
  for (const std::uint32_t r : left_) {
    const Aabb q = fat_.get(r);
    auto report = [&](std::uint32_t j) {
      if (j != r && (!is_left_[j] || r < j)) fresh_.push_back(make_pair(r, j));
    };
    std::uint32_t j = 0;
#if defined(__SSE2__)
    const __m128 qx0 = _mm_set1_ps(q.min[0]), qy0 = _mm_set1_ps(q.min[1]), qz0 = _mm_set1_ps(q.min[2]);
    const __m128 qx1 = _mm_set1_ps(q.max[0]), qy1 = _mm_set1_ps(q.max[1]), qz1 = _mm_set1_ps(q.max[2]);
    for (; j + 4 <= n; j += 4) {
      // x first: few boxes overlap on x (a few percent), so most groups of
      // four stop after two compares.
      __m128 m = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(x0 + j), qx1), _mm_cmpge_ps(_mm_loadu_ps(x1 + j), qx0));
      if (!_mm_movemask_ps(m)) continue;
      m = _mm_and_ps(m, _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(y0 + j), qy1), _mm_cmpge_ps(_mm_loadu_ps(y1 + j), qy0)));
      m = _mm_and_ps(m, _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(z0 + j), qz1), _mm_cmpge_ps(_mm_loadu_ps(z1 + j), qz0)));
      for (unsigned bits = static_cast<unsigned>(_mm_movemask_ps(m)); bits; bits &= bits - 1)
        report(j + static_cast<std::uint32_t>(__builtin_ctz(bits)));
    }
#endif
    for (; j < n; ++j)
      if ((x0[j] <= q.max[0]) & (x1[j] >= q.min[0]) & (y0[j] <= q.max[1]) & (y1[j] >= q.min[1]) &
          (z0[j] <= q.max[2]) & (z1[j] >= q.min[2]))
        report(j);
  }
  for (const std::uint32_t r : left_) is_left_[r] = 0;
  std::sort(fresh_.begin(), fresh_.end());
  merged_.resize(cand_.size() + fresh_.size());
  std::merge(cand_.begin(), cand_.end(), fresh_.begin(), fresh_.end(), merged_.begin());
  cand_.swap(merged_);
  retained::trim(merged_);
  retained::trim(fresh_);
}

void FatMovingPairs::give_up() {
  valid_ = false;
  last_rebuilt_ = false;
  cooldown_ = next_cooldown_;
  next_cooldown_ = std::min(2 * next_cooldown_, kMaxCooldownFrames);
  cand_.clear();
  retained::trim(cand_);
}

void FatMovingPairs::release() {
  fat_ = BoxArray();
  std::vector<Pair>().swap(cand_);
  std::vector<Pair>().swap(fresh_);
  std::vector<Pair>().swap(merged_);
  std::vector<std::uint32_t>().swap(left_);
  std::vector<std::uint8_t>().swap(is_left_);
  valid_ = false;
}

}  // namespace hbp::detail
