// SPDX-License-Identifier: MIT
#pragma once
// Bullet's narrow phase as a baseline: btCollisionDispatcher with the
// default collision configuration (btConvexConvexAlgorithm: GJK + EPA, and
// btBoxBoxCollisionAlgorithm for box pairs), zero margins, on the pairs our
// broad phase reports. Persistent: each pair keeps its algorithm and contact
// manifold from frame to frame, as in a Bullet world ("steady state").
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "hbp/pair.hpp"
#include "hbp/shape.hpp"

namespace hbp::baselines {

class BulletNarrowPhase {
 public:
  // One collision object per shape (the count is fixed for the lifetime).
  explicit BulletNarrowPhase(const std::vector<Shape>& shapes);
  ~BulletNarrowPhase();
  BulletNarrowPhase(const BulletNarrowPhase&) = delete;
  BulletNarrowPhase& operator=(const BulletNarrowPhase&) = delete;

  // Untimed set-up of a frame: moves every object to its shape's pose,
  // creates the algorithm and manifold of each pair new in `sorted_pairs`
  // (sorted, canonical) by running it once, and frees those of pairs gone.
  void prepare(const std::vector<Shape>& shapes, const std::vector<Pair>& sorted_pairs);
  // The timed part: processCollision on every pair of the frame. colliding[k]
  // = 1 if pair k's manifold holds a point at distance <= 0. Returns the
  // number of colliding pairs.
  std::size_t run(std::vector<std::uint8_t>& colliding);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp::baselines
