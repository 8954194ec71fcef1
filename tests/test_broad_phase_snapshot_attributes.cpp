// SPDX-License-Identifier: MIT
// Snapshots of what an object carries besides its box: Box2D filters, user
// data, margins, sweeps in progress, and the double boxes of a
// double_precision broad phase. A world built by random edits is
// snapshotted at random points and restored into a fresh object; both then
// take the same random edits for 100 frames and must report the same pairs,
// created and removed, return the same handles and read back the same
// attributes. A double_precision snapshot is refused by a float broad phase
// and the reverse, the object unchanged.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "hbp/aabb_d.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"

namespace {

using hbp::Aabb;
using hbp::AabbD;
using hbp::BroadPhase;
using hbp::Filter;
using hbp::Handle;

// Random edits applied identically to every world of `worlds` (the same
// random stream drives each call once, applied to all).
class Twins {
 public:
  Twins(bool doubles, unsigned seed) : doubles_(doubles), rng_(seed) {}

  void edit(std::vector<BroadPhase*> worlds) {
    const int op = static_cast<int>(rng_() % 10);
    if (live_.size() < 40 || op == 0) return add(worlds);
    if (op <= 3) return move(worlds);
    if (op == 4) return remove(worlds);
    const std::vector<Handle> some = pick(1 + rng_() % 6);
    if (op == 5) {
      const bool to_static = rng_() % 2;
      for (BroadPhase* w : worlds) w->set_static(some, to_static);
    } else if (op == 6) {
      const Filter f = random_filter();
      for (BroadPhase* w : worlds) w->set_filter(some, f);
    } else if (op == 7) {
      std::vector<std::uint64_t> values(some.size());
      for (auto& v : values) v = rng_();
      for (BroadPhase* w : worlds) w->set_user_data(some, values);
    } else if (op == 8 && !doubles_) {
      const float m = static_cast<float>(rng_() % 3) * 0.25f;
      for (BroadPhase* w : worlds) w->set_margin(some, m);
    } else {
      move(worlds);
    }
  }

 private:
  Filter random_filter() {
    Filter f;
    f.category = 1ull << (rng_() % 4);
    f.mask = ~0ull ^ (rng_() % 3 == 0 ? 1ull << (rng_() % 4) : 0);
    f.group = static_cast<std::int32_t>(rng_() % 5) - 2;
    return f;
  }
  Aabb random_box() {
    std::uniform_real_distribution<float> at(0.0f, 60.0f), size(0.5f, 4.0f);
    Aabb b;
    for (int k = 0; k < 3; ++k) {
      b.min[k] = at(rng_);
      b.max[k] = b.min[k] + size(rng_);
    }
    return b;
  }
  // Far from the origin, off the float grid: the double path's rounding.
  AabbD as_double(const Aabb& b) {
    AabbD d;
    for (int k = 0; k < 3; ++k) {
      d.min[k] = 1e7 + b.min[k] + 1e-3 * static_cast<double>(rng_() % 7);
      d.max[k] = 1e7 + b.max[k];
    }
    return d;
  }
  std::vector<Handle> pick(std::size_t n) {
    std::vector<Handle> out;
    std::vector<Handle> pool = live_;
    for (std::size_t i = 0; i < n && !pool.empty(); ++i) {
      const std::size_t k = rng_() % pool.size();
      out.push_back(pool[k]);
      pool.erase(pool.begin() + static_cast<std::ptrdiff_t>(k));
    }
    return out;
  }
  void add(std::vector<BroadPhase*> worlds) {
    const std::size_t n = 1 + rng_() % 8;
    std::vector<Aabb> boxes(n);
    for (auto& b : boxes) b = random_box();
    hbp::AddOptions o{.is_static = rng_() % 3 == 0, .layer = 0, .filter = random_filter(), .user_data = rng_(),
                      .margin = doubles_ ? 0.0f : static_cast<float>(rng_() % 2) * 0.5f};
    std::vector<AabbD> d;
    for (const Aabb& b : boxes) d.push_back(as_double(b));
    std::vector<Handle> first;
    for (BroadPhase* w : worlds) {
      const std::vector<Handle> h = doubles_ ? w->add(d, o) : w->add(boxes, o);
      if (first.empty()) first = h;
      ASSERT_EQ(h, first) << "handles of the restored world differ";
    }
    live_.insert(live_.end(), first.begin(), first.end());
  }
  void move(std::vector<BroadPhase*> worlds) {
    const std::vector<Handle> h = pick(1 + rng_() % 20);
    std::vector<Aabb> boxes(h.size());
    for (auto& b : boxes) b = random_box();
    std::vector<AabbD> d;
    for (const Aabb& b : boxes) d.push_back(as_double(b));
    const bool swept = !doubles_ && rng_() % 3 == 0;
    for (BroadPhase* w : worlds) {
      if (doubles_)
        w->move(h, d);
      else if (swept)
        w->move_swept(h, boxes);
      else
        w->move(h, boxes);
    }
  }
  void remove(std::vector<BroadPhase*> worlds) {
    const std::vector<Handle> h = pick(1 + rng_() % 4);
    for (BroadPhase* w : worlds) w->remove(h);
    for (const Handle x : h) live_.erase(std::find(live_.begin(), live_.end(), x));
  }

 public:
  const std::vector<Handle>& live() const { return live_; }

 private:
  bool doubles_;
  std::mt19937_64 rng_;
  std::vector<Handle> live_;
};

void expect_same_objects(const BroadPhase& a, const BroadPhase& b, const std::vector<Handle>& live, bool doubles) {
  ASSERT_EQ(a.size(), b.size());
  for (const Handle h : live) {
    ASSERT_TRUE(b.contains(h));
    EXPECT_EQ(a.filter(h), b.filter(h)) << "handle " << h;
    EXPECT_EQ(a.user_data(h), b.user_data(h)) << "handle " << h;
    EXPECT_EQ(a.margin(h), b.margin(h)) << "handle " << h;
    EXPECT_EQ(a.is_static(h), b.is_static(h)) << "handle " << h;
    if (doubles) {
      const AabbD x = a.box_d(h), y = b.box_d(h);
      EXPECT_EQ(x.min, y.min) << "handle " << h;
      EXPECT_EQ(x.max, y.max) << "handle " << h;
    }
  }
}

void run(bool doubles, unsigned seed, unsigned threads) {
  const hbp::BroadPhaseOptions options{.threads = threads, .double_precision = doubles};
  BroadPhase original(options);
  Twins edits(doubles, seed);
  std::mt19937 when(seed);
  for (int round = 0; round < 4; ++round) {
    const int frames = 20 + static_cast<int>(when() % 40);
    for (int f = 0; f < frames; ++f) {
      for (int e = 0; e < 6; ++e) {
        edits.edit({&original});
        ASSERT_FALSE(testing::Test::HasFatalFailure());
      }
      original.update();
    }
    for (int e = 0; e < 3; ++e) edits.edit({&original});  // a snapshot mid-frame: pending edits
    const std::vector<std::byte> data = original.snapshot();
    BroadPhase restored = BroadPhase::from_snapshot(data, options);
    expect_same_objects(original, restored, edits.live(), doubles);
    for (int f = 0; f < 100; ++f) {
      const hbp::BroadPhaseUpdate& a = original.update();
      const hbp::BroadPhaseUpdate& b = restored.update();
      ASSERT_EQ(a.pairs, b.pairs) << "frame " << f << " after the restore";
      ASSERT_EQ(a.created, b.created) << "frame " << f;
      ASSERT_EQ(a.removed, b.removed) << "frame " << f;
      for (int e = 0; e < 6; ++e) {
        edits.edit({&original, &restored});
        ASSERT_FALSE(testing::Test::HasFatalFailure());
      }
    }
    expect_same_objects(original, restored, edits.live(), doubles);
  }
}

TEST(BroadPhaseSnapshotAttributes, FiltersUserDataMarginsAndSweepsRestore) {
  for (unsigned seed : {1u, 2u, 3u}) run(false, seed, seed == 2 ? 2u : 1u);
}

TEST(BroadPhaseSnapshotAttributes, DoubleBoxesRestore) {
  for (unsigned seed : {4u, 5u}) run(true, seed, seed == 5 ? 2u : 1u);
}

TEST(BroadPhaseSnapshotAttributes, PrecisionMustMatch) {
  BroadPhase doubles({.double_precision = true});
  const Handle hd = doubles.add(AabbD{{1e8, 1e8, 1e8}, {1e8 + 1, 1e8 + 1, 1e8 + 1}});
  BroadPhase floats;
  const Handle h = floats.add(Aabb{{0, 0, 0}, {1, 1, 1}});
  const std::vector<std::byte> from_doubles = doubles.snapshot(), from_floats = floats.snapshot();
  EXPECT_THROW(floats.restore(from_doubles), hbp::InvalidInput);
  EXPECT_EQ(floats.size(), 1u);  // unchanged
  EXPECT_TRUE(floats.contains(h));
  EXPECT_THROW(doubles.restore(from_floats), hbp::InvalidInput);
  EXPECT_EQ(doubles.size(), 1u);
  BroadPhase again({.double_precision = true});
  again.restore(from_doubles);
  EXPECT_EQ(again.box_d(hd).min[0], 1e8);
}

}  // namespace
