// SPDX-License-Identifier: MIT
// Bullet's bt32BitAxisSweep3: incremental sweep and prune over 32-bit
// quantised endpoints on three axes, with an incremental pair cache.
// createProxy() inserts each endpoint by walking the sorted edge lists from
// the end, so setting up n proxies costs O(n^2) (about 13 s for 20,000 here);
// the benchmark budgets for that and skips large worlds.
#include <algorithm>
#include <memory>
#include <vector>

#include "hbp/baselines/baseline.hpp"
#include "hbp/bullet/bullet_headers.hpp"
#include "baselines/bullet_pairs.hpp"
#include "baselines/reported_pairs.hpp"

namespace hbp::baselines {
namespace {

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
      world = box_bounds(boxes);
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
    proxies_.create(*broadphase_, boxes);
  }

  void update(const BoxArray& boxes) override { proxies_.update(*broadphase_, boxes); }
  std::size_t raw_pairs() const override { return proxies_.raw_pairs(broadphase_.get()); }
  const std::vector<Pair>& exact_pairs() override { return proxies_.exact_pairs(broadphase_.get()); }

 private:
  BaselineOptions options_;
  std::unique_ptr<bt32BitAxisSweep3> broadphase_;
  BulletProxies proxies_;
};

}  // namespace

std::unique_ptr<Baseline> make_bullet_axis_sweep(const BaselineOptions& options) {
  return std::make_unique<BulletAxisSweep>(options);
}

}  // namespace hbp::baselines
