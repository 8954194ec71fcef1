// SPDX-License-Identifier: MIT
// Links the installed package: a small Bullet world with
// hbp::bullet::BroadphaseAdapter, plus the core hbp::HybridBroadPhase directly.
// Exits 0 when both find the expected pairs.
#include <cstdio>

#include <btBulletDynamicsCommon.h>

#include "hbp/bullet/broadphase_adapter.hpp"
#include "hbp/hybrid_broadphase.hpp"

int main() {
  // The core library: three boxes, two touching.
  hbp::BoxArray boxes;
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});
  boxes.push_back({{1, 0, 0}, {2, 1, 1}});
  boxes.push_back({{5, 5, 5}, {6, 6, 6}});
  hbp::HybridBroadPhase core({.threads = 1});
  const auto& pairs = core.update(boxes);
  if (pairs.size() != 1 || pairs[0].a != 0 || pairs[0].b != 1) {
    std::fprintf(stderr, "core: expected pair 0-1, got %zu pairs\n", pairs.size());
    return 1;
  }

  // A Bullet world: a sphere dropped onto a static box comes to rest on it.
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher(&configuration);
  hbp::bullet::BroadphaseAdapter broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &configuration);
  world.setGravity(btVector3(0, -10, 0));
  btBoxShape ground_shape(btVector3(5, 0.5f, 5));
  btRigidBody ground(btRigidBody::btRigidBodyConstructionInfo(0, nullptr, &ground_shape));
  ground.getWorldTransform().setOrigin(btVector3(0, -0.5f, 0));
  btSphereShape ball_shape(0.5f);
  btVector3 inertia;
  ball_shape.calculateLocalInertia(1, inertia);
  btRigidBody ball(btRigidBody::btRigidBodyConstructionInfo(1, nullptr, &ball_shape, inertia));
  ball.getWorldTransform().setOrigin(btVector3(0, 3, 0));
  world.addRigidBody(&ground);
  world.addRigidBody(&ball);
  for (int i = 0; i < 180; ++i) world.stepSimulation(1.0f / 60, 0);
  const float y = ball.getWorldTransform().getOrigin().y();
  const int cached = broadphase.getOverlappingPairCache()->getNumOverlappingPairs();
  world.removeRigidBody(&ball);
  world.removeRigidBody(&ground);
  if (y < 0.4f || y > 0.6f || cached != 1) {
    std::fprintf(stderr, "bullet: ball at y = %g, %d cached pairs (expected 0.5, 1)\n", y, cached);
    return 1;
  }
  std::printf("consumer OK: core pair 0-1, ball resting at y = %.3f, %d cached pair\n", y, cached);
  return 0;
}
