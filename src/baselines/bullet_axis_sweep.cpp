// Bullet's bt32BitAxisSweep3: incremental sweep and prune over 32-bit
// quantised endpoints on three axes, with an incremental pair cache.
// createProxy() inserts each endpoint by walking the sorted edge lists from
// the end, so setting up n proxies costs O(n^2) (about 13 s for 20,000 here);
// the benchmark budgets for that and skips large worlds.
#include <algorithm>
#include <memory>
#include <vector>

#include "baselines/baseline.hpp"
#include "baselines/bullet_headers.hpp"
#include "baselines/bullet_pairs.hpp"

namespace hbp::baselines {
namespace {

Aabb bounds_of(const BoxArray& boxes) {
  Aabb w{{0, 0, 0}, {1, 1, 1}};
  if (boxes.empty()) return w;
  for (int k = 0; k < 3; ++k) {
    const float* lo = boxes.min(k);
    const float* hi = boxes.max(k);
    w.min[k] = *std::min_element(lo, lo + boxes.size());
    w.max[k] = *std::max_element(hi, hi + boxes.size());
  }
  return w;
}

class BulletAxisSweep final : public Baseline {
 public:
  explicit BulletAxisSweep(const BaselineOptions& options) : options_(options) {}

  std::string name() const override { return "bullet-axis-sweep"; }
  std::string label() const override { return "Bullet AxisSweep3"; }

  void setup(const BoxArray& boxes) override {
    // The destructor frees every handle at once; destroyProxy() one by one
    // would be quadratic again (each removal walks the edge lists).
    broadphase_.reset();
    proxies_.clear();
    Aabb world = options_.world;
    if (!(world.min[0] <= world.max[0] && world.min[1] <= world.max[1] && world.min[2] <= world.max[2])) {
      world = bounds_of(boxes);
      for (int k = 0; k < 3; ++k) {
        const float grow = std::max(1.0f, 0.25f * (world.max[k] - world.min[k]));
        world.min[k] -= grow;
        world.max[k] += grow;
      }
    }
    const auto n = static_cast<std::uint32_t>(boxes.size());
    // The raycast accelerator (a second, DBVT broad phase kept in step with
    // every update) only serves ray queries: disabled, as the benchmark
    // measures pair finding alone.
    broadphase_ = std::make_unique<bt32BitAxisSweep3>(btVector3(world.min[0], world.min[1], world.min[2]),
                                                      btVector3(world.max[0], world.max[1], world.max[2]),
                                                      std::max<std::uint32_t>(n, 1), nullptr, true);
    proxies_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      proxies_[i] = broadphase_->createProxy(bullet_min(boxes, i), bullet_max(boxes, i), BOX_SHAPE_PROXYTYPE,
                                             bullet_user_pointer(i), btBroadphaseProxy::DefaultFilter,
                                             btBroadphaseProxy::AllFilter, nullptr);
    }
    broadphase_->calculateOverlappingPairs(nullptr);
    boxes_ = &boxes;
    dirty_ = true;
  }

  void update(const BoxArray& boxes) override {
    const std::size_t n = proxies_.size();
    for (std::size_t i = 0; i < n; ++i)
      broadphase_->setAabb(proxies_[i], bullet_min(boxes, i), bullet_max(boxes, i), nullptr);
    broadphase_->calculateOverlappingPairs(nullptr);
    boxes_ = &boxes;
    dirty_ = true;
  }

  std::size_t raw_pairs() const override {
    return broadphase_ ? static_cast<std::size_t>(broadphase_->getOverlappingPairCache()->getNumOverlappingPairs())
                       : 0;
  }

  const std::vector<Pair>& exact_pairs() override {
    if (dirty_ && broadphase_ && boxes_) {
      exact_bullet_pairs(*broadphase_->getOverlappingPairCache(), *boxes_, exact_);
      dirty_ = false;
    }
    return exact_;
  }

 private:
  BaselineOptions options_;
  std::unique_ptr<bt32BitAxisSweep3> broadphase_;
  std::vector<btBroadphaseProxy*> proxies_;
  const BoxArray* boxes_ = nullptr;
  std::vector<Pair> exact_;
  bool dirty_ = false;
};

}  // namespace

std::unique_ptr<Baseline> make_bullet_axis_sweep(const BaselineOptions& options) {
  return std::make_unique<BulletAxisSweep>(options);
}

}  // namespace hbp::baselines
