// SPDX-License-Identifier: MIT
#pragma once
// The example world: spheres, boxes, cylinders and cones (random sizes and
// orientations, seeded) dropped from a grid into an open box container
// (floor and four walls, static). Every 16th body is "debris": its own filter
// group, masked against itself, so debris passes through debris and the
// broad phase's group/mask filtering is exercised.
//
// Bodies carry their index as the collision object's user index (container
// parts first: floor 0, walls 1..4, then the falling bodies).
#include <cstdint>
#include <memory>
#include <vector>

#include "hbp/bullet/bullet_headers.hpp"
#include "integrations/world/recording_dispatcher.hpp"

namespace hbp::bullet::world {

struct FallingShapesConfig {
  std::uint32_t bodies = 5000;  // falling bodies (the container adds 5)
  std::uint32_t seed = 1;
  std::uint32_t layers_hint = 20;  // bodies per grid column, about
  float spacing = 2.0f;            // grid pitch (m); bodies fit in a 1 m ball
};

struct ContactCount {
  std::uint64_t manifolds = 0;  // manifolds holding at least one point
  std::uint64_t points = 0;
};

// Collision detection timings of the last step (ms): updateAabbs()
// (btDbvtBroadphase moves its tree leaves there) and computeOverlappingPairs(),
// wall time and CPU time of the whole process (every thread).
struct BroadphaseTiming {
  double update_aabbs_ms = 0;
  double pairs_ms = 0;
  double update_aabbs_cpu_ms = 0;
  double pairs_cpu_ms = 0;
};

class FallingShapesWorld {
 public:
  FallingShapesWorld(const FallingShapesConfig& config, std::unique_ptr<btBroadphaseInterface> broadphase);
  ~FallingShapesWorld();
  FallingShapesWorld(const FallingShapesWorld&) = delete;
  FallingShapesWorld& operator=(const FallingShapesWorld&) = delete;

  // One fixed step of `dt` seconds (no sub-stepping, no interpolation).
  void step(float dt = 1.0f / 60.0f);

  // Copies every body's dynamic state (transforms, velocities, activation)
  // from a world built with the same configuration.
  void copy_state_from(const FallingShapesWorld& other);

  ContactCount contacts() const;
  std::size_t body_count() const { return bodies_.size(); }  // container included
  btRigidBody& body(std::size_t i) { return *bodies_[i]; }
  const btRigidBody& body(std::size_t i) const { return *bodies_[i]; }
  btDiscreteDynamicsWorld& dynamics() { return *world_; }
  btBroadphaseInterface& broadphase() { return *broadphase_; }
  RecordingDispatcher& dispatcher() { return *dispatcher_; }
  const BroadphaseTiming& timing() const;
  static constexpr int kDebrisGroup = 64;

 private:
  class TimedWorld;
  std::unique_ptr<btDefaultCollisionConfiguration> configuration_;
  std::unique_ptr<RecordingDispatcher> dispatcher_;
  std::unique_ptr<btBroadphaseInterface> broadphase_;
  std::unique_ptr<btSequentialImpulseConstraintSolver> solver_;
  std::unique_ptr<btDiscreteDynamicsWorld> world_;  // a TimedWorld
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btRigidBody>> bodies_;
};

}  // namespace hbp::bullet::world
