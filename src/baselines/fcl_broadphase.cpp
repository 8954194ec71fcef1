// SPDX-License-Identifier: MIT
// FCL's broad-phase collision managers (the robotics stack's broad phase:
// MoveIt, Drake's predecessors, OMPL): DynamicAABBTreeCollisionManager,
// SaPCollisionManager, IntervalTreeCollisionManager and
// SpatialHashingCollisionManager, run as FCL's users run them: one
// CollisionObject per object registered once, then each frame every object's
// AABB recomputed, manager->update(), manager->collide(callback).
//
// Each object's geometry carries the frame's box as its local AABB under an
// identity transform, so CollisionObject::computeAABB() reproduces our float
// box in double (a rotated transform would make FCL bound the object by a
// sphere, and every system here gets the same tight boxes), grown on every
// side by a margin of two float epsilons of the world's largest coordinate
// (a few float ulps): FCL treats boxes that only touch as apart (its interval
// tree and SaP order equal endpoints either way; its spatial hash puts a box
// ending exactly on a cell boundary and one starting there in different
// cells, and one double ulp of growth is lost in its (x - scene min) / cell
// arithmetic), so without the margin it misses touching pairs. The
// closed-box test then drops the few extra pairs, as with Bullet's fattened
// leaves.
//
// SaPCollisionManager is rebuilt every frame (clear + registerObjects: sort
// the endpoints, sweep): FCL 0.7's incremental SaPCollisionManager::update_
// only handles boxes whose two endpoints move the same way on an axis; a box
// that grows or shrinks (every rotating object) links an endpoint to itself
// and the next update loops forever.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include <fcl/broadphase/broadphase_SaP.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_interval_tree.h>
#include <fcl/broadphase/broadphase_spatialhash.h>
#include <fcl/config.h>
#include <fcl/geometry/shape/box.h>

#include "hbp/baselines/baseline.hpp"
#include "baselines/reported_pairs.hpp"
#include "hbp/error.hpp"

namespace hbp::baselines {
namespace {

void* fcl_user_data(std::uint32_t index) { return reinterpret_cast<void*>(static_cast<std::uintptr_t>(index)); }
std::uint32_t fcl_index(const fcl::CollisionObjectd* o) {
  return static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(o->getUserData()));
}

void set_local_box(fcl::CollisionGeometryd& g, const BoxArray& boxes, std::size_t i, double margin) {
  g.aabb_local.min_ = {boxes.min(0)[i] - margin, boxes.min(1)[i] - margin, boxes.min(2)[i] - margin};
  g.aabb_local.max_ = {boxes.max(0)[i] + margin, boxes.max(1)[i] + margin, boxes.max(2)[i] + margin};
  g.aabb_center = g.aabb_local.center();
  g.aabb_radius = 0.5 * (g.aabb_local.max_ - g.aabb_local.min_).norm();
}

bool collect(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
  static_cast<ReportedPairs*>(data)->add(fcl_index(a), fcl_index(b));
  return false;  // keep going: we want every pair
}

enum class FclManager { DynamicAabbTree, SaP, IntervalTree, SpatialHash };

// Registry name and table label of each manager.
struct FclNames {
  const char* name;
  const char* label;
};
FclNames fcl_names(FclManager kind) {
  switch (kind) {
    case FclManager::DynamicAabbTree: return {"fcl-dynamic-aabb-tree", "FCL DynamicAABBTree"};
    case FclManager::SaP: return {"fcl-sap", "FCL SaP"};
    case FclManager::IntervalTree: return {"fcl-interval-tree", "FCL IntervalTree"};
    case FclManager::SpatialHash: return {"fcl-spatial-hash", "FCL SpatialHash"};
  }
  return {"fcl", "FCL"};
}

class FclBroadphase final : public ReportingBaseline {
 public:
  FclBroadphase(FclManager kind, const BaselineOptions& options)
      : ReportingBaseline(fcl_names(kind).name, fcl_names(kind).label), kind_(kind), options_(options) {}

  void setup(const BoxArray& boxes) override {
    manager_.reset();
    objects_.clear();
    geometries_.clear();
    pairs_.clear();
    manager_ = make_manager(boxes);
    const Aabb world = grown_bounds(boxes);
    double largest = 1;
    for (int k = 0; k < 3; ++k) largest = std::max({largest, std::abs(double(world.min[k])), std::abs(double(world.max[k]))});
    margin_ = 2 * std::numeric_limits<float>::epsilon() * largest;
    const auto n = static_cast<std::uint32_t>(boxes.size());
    objects_.reserve(n);
    geometries_.reserve(n);
    raw_objects_.assign(n, nullptr);
    for (std::uint32_t i = 0; i < n; ++i) {
      // A unit box whose local AABB is then replaced by the object's box.
      auto geometry = std::make_shared<fcl::Boxd>(1, 1, 1);
      geometries_.push_back(geometry);
      objects_.push_back(std::make_unique<fcl::CollisionObjectd>(geometry));
      set_local_box(*geometry, boxes, i, margin_);
      objects_.back()->computeAABB();
      objects_.back()->setUserData(fcl_user_data(i));
      raw_objects_[i] = objects_.back().get();
    }
    manager_->registerObjects(raw_objects_);
    manager_->setup();
    collide(boxes);
  }

  std::size_t object_count() const override { return objects_.size(); }

  void move_objects(const BoxArray& boxes) override {
    for (std::size_t i = 0; i < objects_.size(); ++i) {
      set_local_box(*geometries_[i], boxes, i, margin_);
      objects_[i]->computeAABB();
    }
    if (kind_ == FclManager::SaP) {
      manager_->clear();
      manager_->registerObjects(raw_objects_);
      manager_->setup();
    } else {
      manager_->update();
    }
  }

  void collide(const BoxArray& boxes) override {
    pairs_.begin(boxes);
    manager_->collide(&pairs_, collect);
  }

 private:
  std::unique_ptr<fcl::BroadPhaseCollisionManagerd> make_manager(const BoxArray& boxes) const {
    switch (kind_) {
      case FclManager::DynamicAabbTree: return std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>();
      case FclManager::SaP: return std::make_unique<fcl::SaPCollisionManagerd>();
      case FclManager::IntervalTree: return std::make_unique<fcl::IntervalTreeCollisionManagerd>();
      case FclManager::SpatialHash: {
        // The scene limits a user gives: the world of BaselineOptions, else
        // the first frame's bounds grown; cells of about one object (twice
        // the mean largest extent), the size FCL's own tests use relative
        // to their objects. Objects outside the limits are still found
        // (FCL keeps them in a list tested against everything).
        Aabb world = options_.world;
        if (!(world.min[0] <= world.max[0] && world.min[1] <= world.max[1] && world.min[2] <= world.max[2]))
          world = grown_bounds(boxes);
        const double cell = 2 * mean_largest_extent(boxes);
        return std::make_unique<fcl::SpatialHashingCollisionManagerd<>>(
            cell, fcl::Vector3d(world.min[0], world.min[1], world.min[2]),
            fcl::Vector3d(world.max[0], world.max[1], world.max[2]));
      }
    }
    throw Error("fcl: unknown manager");
  }

  FclManager kind_;
  BaselineOptions options_;
  std::vector<std::shared_ptr<fcl::Boxd>> geometries_;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects_;
  std::vector<fcl::CollisionObjectd*> raw_objects_;
  // Declared after the objects it points to, so it is destroyed first.
  std::unique_ptr<fcl::BroadPhaseCollisionManagerd> manager_;
  double margin_ = 0;
};

}  // namespace

std::unique_ptr<Baseline> make_fcl_dynamic_aabb_tree() {
  return std::make_unique<FclBroadphase>(FclManager::DynamicAabbTree, BaselineOptions{});
}
std::unique_ptr<Baseline> make_fcl_sap() { return std::make_unique<FclBroadphase>(FclManager::SaP, BaselineOptions{}); }
std::unique_ptr<Baseline> make_fcl_interval_tree() {
  return std::make_unique<FclBroadphase>(FclManager::IntervalTree, BaselineOptions{});
}
std::unique_ptr<Baseline> make_fcl_spatial_hash(const BaselineOptions& options) {
  return std::make_unique<FclBroadphase>(FclManager::SpatialHash, options);
}

std::string fcl_version() { return FCL_VERSION; }

}  // namespace hbp::baselines
