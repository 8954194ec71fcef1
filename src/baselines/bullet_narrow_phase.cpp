// SPDX-License-Identifier: MIT
#include "hbp/baselines/bullet_narrow_phase.hpp"

#include "baselines/bullet_shapes.hpp"
#include "hbp/error.hpp"

#include "hbp/bullet/bullet_headers.hpp"

namespace hbp::baselines {

struct BulletNarrowPhase::Impl {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDispatcherInfo info;
  std::vector<BulletShape> shapes;
  std::unique_ptr<btCollisionObject[]> objects;
  std::size_t count = 0;
  std::vector<Pair> pairs;                   // this frame's, sorted
  std::vector<btCollisionAlgorithm*> algos;  // per pair

  void release(btCollisionAlgorithm* a) {
    a->~btCollisionAlgorithm();
    dispatcher.freeCollisionAlgorithm(a);
  }

  bool process(const Pair& p, btCollisionAlgorithm* algo) {
    btCollisionObject& oa = objects[p.a];
    btCollisionObject& ob = objects[p.b];
    btCollisionObjectWrapper wa(nullptr, oa.getCollisionShape(), &oa, oa.getWorldTransform(), -1, -1);
    btCollisionObjectWrapper wb(nullptr, ob.getCollisionShape(), &ob, ob.getWorldTransform(), -1, -1);
    btManifoldResult result(&wa, &wb);
    algo->processCollision(&wa, &wb, info, &result);
    const btPersistentManifold* m = result.getPersistentManifold();
    if (!m) return false;
    for (int i = 0; i < m->getNumContacts(); ++i)
      if (m->getContactPoint(i).getDistance() <= 0) return true;
    return false;
  }

  btCollisionAlgorithm* create(const Pair& p) {
    btCollisionObject& oa = objects[p.a];
    btCollisionObject& ob = objects[p.b];
    btCollisionObjectWrapper wa(nullptr, oa.getCollisionShape(), &oa, oa.getWorldTransform(), -1, -1);
    btCollisionObjectWrapper wb(nullptr, ob.getCollisionShape(), &ob, ob.getWorldTransform(), -1, -1);
    btCollisionAlgorithm* a = dispatcher.findAlgorithm(&wa, &wb, nullptr, BT_CONTACT_POINT_ALGORITHMS);
    if (!a) throw Error("Bullet narrow phase: no algorithm for pair " + std::to_string(p.a) + "-" + std::to_string(p.b));
    process(p, a);  // creates the manifold: the timed frames are steady state
    return a;
  }
};

BulletNarrowPhase::BulletNarrowPhase(const std::vector<Shape>& shapes) : impl_(std::make_unique<Impl>()) {
  impl_->count = shapes.size();
  impl_->shapes.reserve(shapes.size());
  impl_->objects = std::make_unique<btCollisionObject[]>(shapes.size());
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    impl_->shapes.push_back(make_bullet_shape(shapes[i]));
    impl_->objects[i].setCollisionShape(impl_->shapes.back().shape());
    impl_->objects[i].setWorldTransform(make_transform(shapes[i]));
  }
}

BulletNarrowPhase::~BulletNarrowPhase() {
  for (btCollisionAlgorithm* a : impl_->algos) impl_->release(a);
}

void BulletNarrowPhase::prepare(const std::vector<Shape>& shapes, const std::vector<Pair>& sorted_pairs) {
  Impl& m = *impl_;
  if (shapes.size() != m.count)
    throw InvalidInput("Bullet narrow phase: " + std::to_string(shapes.size()) + " shapes, built for " +
                       std::to_string(m.count));
  for (std::size_t i = 0; i < shapes.size(); ++i) m.objects[i].setWorldTransform(make_transform(shapes[i]));
  // Merge last frame's sorted pairs with this frame's: keep, create, free.
  std::vector<btCollisionAlgorithm*> algos(sorted_pairs.size(), nullptr);
  std::size_t i = 0;
  for (std::size_t k = 0; k < sorted_pairs.size(); ++k) {
    const Pair p = sorted_pairs[k];
    if (p.a >= m.count || p.b >= m.count)
      throw InvalidInput("Bullet narrow phase: pair " + std::to_string(p.a) + "-" + std::to_string(p.b) +
                         " names an object beyond the " + std::to_string(m.count) + " shapes");
    while (i < m.pairs.size() && m.pairs[i] < p) m.release(m.algos[i++]);
    if (i < m.pairs.size() && m.pairs[i] == p) {
      algos[k] = m.algos[i++];
    } else {
      algos[k] = m.create(p);
    }
  }
  while (i < m.pairs.size()) m.release(m.algos[i++]);
  m.pairs = sorted_pairs;
  m.algos = std::move(algos);
}

std::size_t BulletNarrowPhase::run(std::vector<std::uint8_t>& colliding) {
  Impl& m = *impl_;
  colliding.assign(m.pairs.size(), 0);
  std::size_t hits = 0;
  for (std::size_t k = 0; k < m.pairs.size(); ++k) {
    colliding[k] = m.process(m.pairs[k], m.algos[k]) ? 1 : 0;
    hits += colliding[k];
  }
  return hits;
}

}  // namespace hbp::baselines
