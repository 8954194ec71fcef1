// SPDX-License-Identifier: MIT
#include "integrations/world/falling_shapes_world.hpp"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "support/clock.hpp"

namespace hbp::bullet::world {

// Times the two collision-detection stages that belong to the broad phase.
class FallingShapesWorld::TimedWorld final : public btDiscreteDynamicsWorld {
 public:
  using btDiscreteDynamicsWorld::btDiscreteDynamicsWorld;
  void updateAabbs() override {
    const auto t = SteadyClock::now();
    const double c = cpu_ms();
    btDiscreteDynamicsWorld::updateAabbs();
    timing.update_aabbs_cpu_ms = cpu_ms() - c;
    timing.update_aabbs_ms = ms_since(t);
  }
  void computeOverlappingPairs() override {
    const auto t = SteadyClock::now();
    const double c = cpu_ms();
    btDiscreteDynamicsWorld::computeOverlappingPairs();
    timing.pairs_cpu_ms = cpu_ms() - c;
    timing.pairs_ms = ms_since(t);
  }
  BroadphaseTiming timing;

 private:
  static double cpu_ms() {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
  }
};

namespace {

// Same numbers on every standard library (std::uniform_real_distribution is
// implementation-defined).
float uniform(std::mt19937& rng, float lo, float hi) {
  return lo + (hi - lo) * static_cast<float>(rng() >> 8) * (1.0f / 16777216.0f);
}

std::unique_ptr<btCollisionShape> random_shape(std::mt19937& rng, std::uint32_t kind, float& volume) {
  constexpr float kPi = 3.14159265f;
  switch (kind) {
    case 0: {
      const float r = uniform(rng, 0.2f, 0.5f);
      volume = 4.0f / 3.0f * kPi * r * r * r;
      return std::make_unique<btSphereShape>(r);
    }
    case 1: {
      const btVector3 h(uniform(rng, 0.15f, 0.5f), uniform(rng, 0.15f, 0.5f), uniform(rng, 0.15f, 0.5f));
      volume = 8.0f * h.x() * h.y() * h.z();
      return std::make_unique<btBoxShape>(h);
    }
    case 2: {
      const float r = uniform(rng, 0.15f, 0.5f);
      const float h = uniform(rng, 0.15f, 0.5f);
      volume = kPi * r * r * 2.0f * h;
      return std::make_unique<btCylinderShape>(btVector3(r, h, r));
    }
    default: {
      const float r = uniform(rng, 0.2f, 0.5f);
      const float h = uniform(rng, 0.4f, 1.0f);
      volume = kPi * r * r * h / 3.0f;
      return std::make_unique<btConeShape>(r, h);
    }
  }
}

}  // namespace

FallingShapesWorld::FallingShapesWorld(const FallingShapesConfig& config,
                                       std::unique_ptr<btBroadphaseInterface> broadphase)
    : configuration_(std::make_unique<btDefaultCollisionConfiguration>()),
      dispatcher_(std::make_unique<RecordingDispatcher>(configuration_.get())),
      broadphase_(std::move(broadphase)),
      solver_(std::make_unique<btSequentialImpulseConstraintSolver>()) {
  auto world = std::make_unique<TimedWorld>(dispatcher_.get(), broadphase_.get(), solver_.get(),
                                            configuration_.get());
  world->setGravity(btVector3(0, -9.81f, 0));
  world_ = std::move(world);

  const auto columns = static_cast<std::uint32_t>(
      std::max(2.0, std::ceil(std::sqrt(static_cast<double>(config.bodies) / std::max(1u, config.layers_hint)))));
  const float half = 0.5f * config.spacing * static_cast<float>(columns);  // inner half width
  constexpr float kWallHalfHeight = 4.0f;

  auto add_static = [&](const btVector3& half_extents, const btVector3& centre) {
    shapes_.push_back(std::make_unique<btBoxShape>(half_extents));
    btRigidBody::btRigidBodyConstructionInfo info(0.0f, nullptr, shapes_.back().get());
    info.m_startWorldTransform.setIdentity();
    info.m_startWorldTransform.setOrigin(centre);
    bodies_.push_back(std::make_unique<btRigidBody>(info));
    bodies_.back()->setUserIndex(static_cast<int>(bodies_.size() - 1));
    world_->addRigidBody(bodies_.back().get());
  };
  add_static(btVector3(half + 1.0f, 0.5f, half + 1.0f), btVector3(0, -0.5f, 0));  // floor, top at y = 0
  add_static(btVector3(0.5f, kWallHalfHeight, half + 1.0f), btVector3(-half - 0.5f, kWallHalfHeight, 0));
  add_static(btVector3(0.5f, kWallHalfHeight, half + 1.0f), btVector3(half + 0.5f, kWallHalfHeight, 0));
  add_static(btVector3(half + 1.0f, kWallHalfHeight, 0.5f), btVector3(0, kWallHalfHeight, -half - 0.5f));
  add_static(btVector3(half + 1.0f, kWallHalfHeight, 0.5f), btVector3(0, kWallHalfHeight, half + 0.5f));

  std::mt19937 rng(config.seed);
  const float jitter = 0.05f * config.spacing;
  for (std::uint32_t i = 0; i < config.bodies; ++i) {
    const std::uint32_t layer = i / (columns * columns);
    const std::uint32_t ix = i % columns;
    const std::uint32_t iz = (i / columns) % columns;
    float volume = 0;
    shapes_.push_back(random_shape(rng, rng() % 4, volume));
    btCollisionShape* shape = shapes_.back().get();
    const float mass = 1000.0f * volume;  // water density
    btVector3 inertia(0, 0, 0);
    shape->calculateLocalInertia(mass, inertia);
    btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, shape, inertia);
    info.m_startWorldTransform.setIdentity();
    info.m_startWorldTransform.setOrigin(
        btVector3(-half + config.spacing * (static_cast<float>(ix) + 0.5f) + uniform(rng, -jitter, jitter),
                  1.5f + config.spacing * static_cast<float>(layer) + uniform(rng, -jitter, jitter),
                  -half + config.spacing * (static_cast<float>(iz) + 0.5f) + uniform(rng, -jitter, jitter)));
    btQuaternion q;
    q.setEulerZYX(uniform(rng, -3.14159f, 3.14159f), uniform(rng, -1.5f, 1.5f), uniform(rng, -3.14159f, 3.14159f));
    info.m_startWorldTransform.setRotation(q);
    bodies_.push_back(std::make_unique<btRigidBody>(info));
    btRigidBody* body = bodies_.back().get();
    body->setUserIndex(static_cast<int>(bodies_.size() - 1));
    if (i % 16 == 15) {
      world_->addRigidBody(body, kDebrisGroup, btBroadphaseProxy::AllFilter & ~kDebrisGroup);
    } else {
      world_->addRigidBody(body, btBroadphaseProxy::DefaultFilter, btBroadphaseProxy::AllFilter);
    }
  }
}

FallingShapesWorld::~FallingShapesWorld() {
  for (auto it = bodies_.rbegin(); it != bodies_.rend(); ++it) world_->removeRigidBody(it->get());
}

void FallingShapesWorld::step(float dt) { world_->stepSimulation(dt, 0, dt); }

void FallingShapesWorld::copy_state_from(const FallingShapesWorld& other) {
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    btRigidBody& to = *bodies_[i];
    const btRigidBody& from = *other.bodies_[i];
    to.setWorldTransform(from.getWorldTransform());
    to.setInterpolationWorldTransform(from.getInterpolationWorldTransform());
    to.setLinearVelocity(from.getLinearVelocity());
    to.setAngularVelocity(from.getAngularVelocity());
    to.setInterpolationLinearVelocity(from.getInterpolationLinearVelocity());
    to.setInterpolationAngularVelocity(from.getInterpolationAngularVelocity());
    to.forceActivationState(from.getActivationState());
    to.setDeactivationTime(from.getDeactivationTime());
    to.setHitFraction(from.getHitFraction());
  }
}

ContactCount FallingShapesWorld::contacts() const {
  ContactCount c;
  const int n = dispatcher_->getNumManifolds();
  for (int i = 0; i < n; ++i) {
    const int points = dispatcher_->getManifoldByIndexInternal(i)->getNumContacts();
    c.points += static_cast<std::uint64_t>(points);
    c.manifolds += points > 0 ? 1 : 0;
  }
  return c;
}

const BroadphaseTiming& FallingShapesWorld::timing() const {
  return static_cast<const TimedWorld&>(*world_).timing;
}

}  // namespace hbp::bullet::world
