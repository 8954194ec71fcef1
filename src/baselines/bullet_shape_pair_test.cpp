// SPDX-License-Identifier: MIT
#include "hbp/baselines/bullet_shape_pair_test.hpp"
#include "baselines/bullet_shapes.hpp"

#include <memory>

#include "hbp/bullet/bullet_headers.hpp"

namespace hbp::baselines {
namespace {

// A Bullet convex shape stretched by a diagonal matrix S: the support point
// of S*C in direction d is S * s_C(S d).
class ScaledConvex : public btConvexInternalShape {
 public:
  ScaledConvex(const btConvexShape* child, const btVector3& scale) : child_(child), scale_(scale) {
    // A convex type, so btCollisionDispatcher picks its convex-convex
    // algorithm (GJK + EPA through the virtual support mapping).
    m_shapeType = CUSTOM_CONVEX_SHAPE_TYPE;
    setMargin(0);
  }
  btVector3 localGetSupportingVertexWithoutMargin(const btVector3& d) const override {
    const btVector3 sd = d * scale_;
    // The child's full support (a btSphereShape is all margin; the others
    // have zero margin).
    const btVector3 p = child_->localGetSupportingVertex(sd.fuzzyZero() ? btVector3(0, 0, 1) : sd);
    return p * scale_;
  }
  void batchedUnitVectorGetSupportingVertexWithoutMargin(const btVector3* v, btVector3* out,
                                                         int n) const override {
    for (int i = 0; i < n; ++i) out[i] = localGetSupportingVertexWithoutMargin(v[i]);
  }
  void getAabb(const btTransform& t, btVector3& lo, btVector3& hi) const override { getAabbSlow(t, lo, hi); }
  void calculateLocalInertia(btScalar, btVector3& inertia) const override { inertia.setValue(0, 0, 0); }
  const char* getName() const override { return "hbp::ScaledConvex"; }

 private:
  const btConvexShape* child_;
  btVector3 scale_;
};

}  // namespace

BulletShape make_bullet_shape(const Shape& s) {
  const btScalar hx = btScalar(0.5 * s.size.x), hy = btScalar(0.5 * s.size.y), hz = btScalar(0.5 * s.size.z);
  BulletShape b;
  switch (s.kind) {
    case ShapeKind::Cuboid:
      b.child = std::make_unique<btBoxShape>(btVector3(hx, hy, hz));
      b.child->setMargin(0);
      break;
    case ShapeKind::Sphere:
      b.child = std::make_unique<btSphereShape>(btScalar(1));
      b.outer = std::make_unique<ScaledConvex>(b.child.get(), btVector3(hx, hy, hz));
      break;
    case ShapeKind::Cylinder:
      if (s.size.x == s.size.y) {
        b.child = std::make_unique<btCylinderShapeZ>(btVector3(hx, hx, hz));
        b.child->setMargin(0);
      } else {
        b.child = std::make_unique<btCylinderShapeZ>(btVector3(1, 1, hz));
        b.child->setMargin(0);
        b.outer = std::make_unique<ScaledConvex>(b.child.get(), btVector3(hx, hy, 1));
      }
      break;
    case ShapeKind::Cone:
      if (s.size.x == s.size.y) {
        b.child = std::make_unique<btConeShapeZ>(hx, btScalar(2) * hz);
        b.child->setMargin(0);
      } else {
        b.child = std::make_unique<btConeShapeZ>(btScalar(1), btScalar(2) * hz);
        b.child->setMargin(0);
        b.outer = std::make_unique<ScaledConvex>(b.child.get(), btVector3(hx, hy, 1));
      }
      break;
  }
  return b;
}

btTransform make_transform(const Shape& s) {
  const Quat q = normalized(s.orientation);
  return btTransform(btQuaternion(btScalar(q.x), btScalar(q.y), btScalar(q.z), btScalar(q.w)),
                     btVector3(btScalar(s.position.x), btScalar(s.position.y), btScalar(s.position.z)));
}

BulletPairResult bullet_shape_pair_test(const Shape& a, const Shape& b) {
  const BulletShape sa = make_bullet_shape(a), sb = make_bullet_shape(b);
  const btTransform ta = make_transform(a), tb = make_transform(b);
  const btVector3 guess = tb.getOrigin() - ta.getOrigin();
  BulletPairResult r;
  btGjkEpaSolver2::sResults res;
  if (btGjkEpaSolver2::Penetration(sa.shape(), ta, sb.shape(), tb, guess, res)) {
    r.intersecting = true;
    r.signed_distance = res.distance;  // negative: minus the depth
    // Bullet's normal is in a's local frame and points from b into a; ours is
    // in the world frame and points from a to b.
    const btVector3 n = ta.getBasis() * (-res.normal);
    r.normal = {n.x(), n.y(), n.z()};
    return r;
  }
  r.failed = res.status == btGjkEpaSolver2::sResults::GJK_Failed || res.status == btGjkEpaSolver2::sResults::EPA_Failed;
  btGjkEpaSolver2::sResults dres;
  if (btGjkEpaSolver2::Distance(sa.shape(), ta, sb.shape(), tb, guess, dres)) {
    r.signed_distance = dres.distance;
    const btVector3 n = ta.getBasis() * (-dres.normal);  // a's frame, b -> a
    r.normal = {n.x(), n.y(), n.z()};
  }
  return r;
}

Vec3 bullet_support_point(const Shape& s, const Vec3& d) {
  const BulletShape bs = make_bullet_shape(s);
  const btTransform t = make_transform(s);
  const btVector3 local_dir = t.getBasis().transpose() * btVector3(btScalar(d.x), btScalar(d.y), btScalar(d.z));
  const btVector3 p = t * bs.shape()->localGetSupportingVertex(local_dir);
  return {p.x(), p.y(), p.z()};
}

}  // namespace hbp::baselines
