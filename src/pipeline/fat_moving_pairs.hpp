// SPDX-License-Identifier: MIT
#pragma once
// BroadPhase's moving/moving pairs when few objects move (the mostly-static
// world): fat-box candidate pairs kept from frame to frame instead of the
// hybrid system every frame.
//
// Each moving object has a fat box (its box grown by half its largest side,
// as for the static candidates). The candidates are the pairs whose fat
// boxes overlap; while both boxes stay inside their fat boxes every
// overlapping pair is a candidate, so a frame only tests the candidates
// exactly (0.15 per object in the mostly-static benchmark). An object whose
// box left its fat box gets a new one; its candidates are dropped and found
// again by testing its new fat box against every fat box (SSE, a few a
// frame). The candidates are found from
// scratch by the hybrid system run on the fat boxes when the membership
// changed or too many objects left their fat boxes in one frame.
//
// Used only while it pays, that is while the moving objects are sparse among
// themselves: at most kMaxObjects moving objects and kMaxCandidatesPerObject
// fat candidates per object on average (the mostly-static benchmark has
// 0.15; a world of moving objects at the paper's density has 12, where
// testing them costs more than the hybrid system). Otherwise (and after two
// rebuilds in a row, or when the fat pairs pass max_pairs) the caller runs
// the hybrid system on the exact boxes for a cooldown, which doubles each
// time the fat path fails again, so a dense world pays a rebuild rarely.
#include <cstdint>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/pair.hpp"

namespace hbp::detail {

// A fat box: `b` grown by half its largest side on every axis (scale free;
// a zero-size box gets no margin), clamped to the finite floats so a huge
// box still has a valid fat box (any box containing `b` would do).
Aabb fat_box(const Aabb& b);
// in inside out (closed).
inline bool inside(const Aabb& in, const Aabb& out) {
  return in.min[0] >= out.min[0] && in.min[1] >= out.min[1] && in.min[2] >= out.min[2] &&
         in.max[0] <= out.max[0] && in.max[1] <= out.max[1] && in.max[2] <= out.max[2];
}

class FatMovingPairs {
 public:
  static constexpr std::size_t kMaxObjects = 1u << 15;
  static constexpr std::size_t kMaxCandidatesPerObject = 2;
  // Left-box re-tests (objects that left x all objects) above which a frame
  // rebuilds with the hybrid system instead.
  static constexpr std::size_t kMaxRetests = std::size_t(1) << 20;
  // Frames spent on the exact hybrid path after the fat path stopped paying
  // (the first time; doubled each time it fails again, up to the maximum).
  static constexpr std::uint32_t kCooldownFrames = 32;
  static constexpr std::uint32_t kMaxCooldownFrames = 1024;

  // Forgets the candidates (the membership or the dense order changed).
  void reset() { valid_ = false; }

  // The overlapping pairs of `boxes` (dense indices, a < b, sorted by (a, b))
  // into `out`, using `hybrid` for the rebuilds. False when the fat path
  // does not apply this frame: `out` is untouched and the caller runs the
  // hybrid system on the exact boxes. Throws CapacityExceeded past
  // max_pairs exact pairs (0: unlimited), like the hybrid system.
  bool find(const BoxArray& boxes, HybridBroadPhase& hybrid, std::size_t max_pairs, std::vector<Pair>& out);

  // Frees the buffers (no moving objects left).
  void release();

 private:
  bool rebuild(const BoxArray& boxes, HybridBroadPhase& hybrid);
  void retest_left(const BoxArray& boxes);
  // The fat path does not pay now: the exact hybrid path for kCooldownFrames.
  void give_up();

  BoxArray fat_;               // by dense index
  std::vector<Pair> cand_;     // fat boxes overlap: dense, a < b, sorted
  std::vector<Pair> fresh_, merged_;
  std::vector<std::uint32_t> left_;  // objects that left their fat box this frame, ascending
  std::vector<std::uint8_t> is_left_;
  bool valid_ = false;
  bool last_rebuilt_ = false;  // the previous frame rebuilt because too many boxes left
  std::uint32_t cooldown_ = 0;
  std::uint32_t next_cooldown_ = kCooldownFrames;
};

}  // namespace hbp::detail
