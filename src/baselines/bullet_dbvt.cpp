// SPDX-License-Identifier: MIT
// Bullet's btDbvtBroadphase: the paper's CPU baseline (two dynamic AABB trees,
// fattened leaves, incremental pair cache). Defaults, or with deferred
// collision (m_deferedcollide = true: tree-vs-tree collide once per frame
// instead of one tree query per moved proxy).
#include <memory>
#include <vector>

#include "hbp/baselines/baseline.hpp"
#include "hbp/bullet/bullet_headers.hpp"
#include "baselines/bullet_pairs.hpp"

namespace hbp::baselines {
namespace {

class BulletDbvt final : public Baseline {
 public:
  explicit BulletDbvt(bool deferred) : deferred_(deferred) {}
  ~BulletDbvt() override { release(); }

  std::string name() const override { return deferred_ ? "bullet-dbvt-deferred" : "bullet-dbvt"; }
  std::string label() const override { return deferred_ ? "Bullet DBVT deferred" : "Bullet DBVT"; }

  void setup(const BoxArray& boxes) override {
    release();
    // Bullet's default cache type, owned here so release() can detach it.
    cache_ = std::make_unique<btHashedOverlappingPairCache>();
    broadphase_ = std::make_unique<btDbvtBroadphase>(cache_.get());
    broadphase_->m_deferedcollide = deferred_;
    proxies_.create(*broadphase_, boxes);
  }

  void update(const BoxArray& boxes) override { proxies_.update(*broadphase_, boxes); }
  std::size_t raw_pairs() const override { return proxies_.raw_pairs(broadphase_.get()); }
  const std::vector<Pair>& exact_pairs() override { return proxies_.exact_pairs(broadphase_.get()); }

 private:
  void release() {
    if (broadphase_) {
      // destroyProxy() scans the whole pair cache for the proxy's pairs
      // (quadratic over a million proxies): detach the cache first, so each
      // destroyProxy() only unlinks its tree leaf and frees the proxy.
      broadphase_->m_paircache = &null_cache_;
      for (auto* p : proxies_.proxies()) broadphase_->destroyProxy(p, nullptr);
    }
    proxies_.clear();
    broadphase_.reset();
    cache_.reset();
  }

  bool deferred_;
  btNullPairCache null_cache_;
  std::unique_ptr<btHashedOverlappingPairCache> cache_;
  std::unique_ptr<btDbvtBroadphase> broadphase_;
  BulletProxies proxies_;
};

}  // namespace

std::unique_ptr<Baseline> make_bullet_dbvt(bool deferred_collide) {
  return std::make_unique<BulletDbvt>(deferred_collide);
}

}  // namespace hbp::baselines
