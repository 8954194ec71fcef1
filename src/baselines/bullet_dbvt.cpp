// Bullet's btDbvtBroadphase: the paper's CPU baseline (two dynamic AABB trees,
// fattened leaves, incremental pair cache). Defaults, or with deferred
// collision (m_deferedcollide = true: tree-vs-tree collide once per frame
// instead of one tree query per moved proxy).
#include <memory>
#include <vector>

#include "baselines/baseline.hpp"
#include "baselines/bullet_headers.hpp"
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
    const auto n = static_cast<std::uint32_t>(boxes.size());
    proxies_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      proxies_[i] = broadphase_->createProxy(bullet_min(boxes, i), bullet_max(boxes, i), kShapeType,
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
  // Any convex shape type: the broad phase only uses it to tell static or
  // soft bodies apart.
  static constexpr int kShapeType = BOX_SHAPE_PROXYTYPE;

  void release() {
    if (broadphase_) {
      // destroyProxy() scans the whole pair cache for the proxy's pairs
      // (quadratic over a million proxies): detach the cache first, so each
      // destroyProxy() only unlinks its tree leaf and frees the proxy.
      broadphase_->m_paircache = &null_cache_;
      for (auto* p : proxies_) broadphase_->destroyProxy(p, nullptr);
    }
    proxies_.clear();
    broadphase_.reset();
    cache_.reset();
    exact_.clear();
    boxes_ = nullptr;
  }

  bool deferred_;
  btNullPairCache null_cache_;
  std::unique_ptr<btHashedOverlappingPairCache> cache_;
  std::unique_ptr<btDbvtBroadphase> broadphase_;
  std::vector<btBroadphaseProxy*> proxies_;
  const BoxArray* boxes_ = nullptr;
  std::vector<Pair> exact_;
  bool dirty_ = false;
};

}  // namespace

std::unique_ptr<Baseline> make_bullet_dbvt(bool deferred_collide) {
  return std::make_unique<BulletDbvt>(deferred_collide);
}

}  // namespace hbp::baselines
