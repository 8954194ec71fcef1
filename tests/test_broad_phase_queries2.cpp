// SPDX-License-Identifier: MIT
// BroadPhase::raycast_closest and query_box_cast against brute force: long
// randomized edit sequences (static and moving objects added, nudged,
// teleported and removed, updates in between, 1 and 2 threads side by side)
// with rays and casts after every step, each answer against a scan of every
// live object under the library's own scalar rules (RaySegment, BoxCast);
// box casts on a power-of-two lattice also against exact rational
// arithmetic (there the float rule has no rounding).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "grid_boxes.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "pipeline/box_cast.hpp"
#include "pipeline/ray_segment.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Handle;
using Vec3f = BroadPhase::Vec3f;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Hit {
  float t;
  Handle h;
  bool operator<(const Hit& o) const { return t < o.t || (t == o.t && h < o.h); }
};

std::vector<Handle> handles_of(std::vector<Hit> hits) {
  std::sort(hits.begin(), hits.end());
  std::vector<Handle> out;
  for (const Hit& x : hits) out.push_back(x.h);
  return out;
}

std::vector<Hit> scan_ray(const std::map<Handle, Aabb>& objects, const Vec3f& o, const Vec3f& d, float max_t) {
  const hbp::detail::RaySegment ray(o.data(), d.data(), max_t);
  std::vector<Hit> hits;
  for (const auto& [h, b] : objects) {
    float t;
    if (ray.hits(b.min, b.max, t)) hits.push_back({t, h});
  }
  return hits;
}

std::vector<Hit> scan_cast(const std::map<Handle, Aabb>& objects, const Aabb& box, const Vec3f& d) {
  const hbp::detail::BoxCast cast(box, d.data());
  std::vector<Hit> hits;
  for (const auto& [h, b] : objects) {
    float t;
    if (cast.hits(b.min, b.max, t)) hits.push_back({t, h});
  }
  return hits;
}

// Off-grid boxes too, so entry t ties are rare as well as common.
Aabb any_box(std::mt19937& rng, int world) {
  if (rng() % 2) return hbp::test::grid_box(rng, world, 6);
  std::uniform_real_distribution<float> pos(-1.0f, static_cast<float>(world) + 1.0f), size(0.0f, 3.0f);
  Aabb b;
  for (int k = 0; k < 3; ++k) {
    b.min[k] = pos(rng);
    b.max[k] = b.min[k] + size(rng);
  }
  return b;
}

// Directions with zero, tiny, grid and random components.
Vec3f random_direction(std::mt19937& rng) {
  Vec3f d;
  for (float& c : d) {
    switch (rng() % 6) {
      case 0: c = 0.0f; break;
      case 1: c = (rng() % 2 ? 1.0f : -1.0f); break;
      case 2: c = (rng() % 2 ? 1e-39f : -1e-39f); break;  // inverse overflows: parallel
      case 3: c = 0.5f * static_cast<float>(static_cast<int>(rng() % 9) - 4); break;
      default: c = std::uniform_real_distribution<float>(-3.0f, 3.0f)(rng);
    }
  }
  return d;
}

Vec3f random_point(std::mt19937& rng, int world) {
  Vec3f p;
  for (float& c : p)
    c = rng() % 2 ? 0.5f * static_cast<float>(rng() % (2 * world + 3)) - 0.5f
                  : std::uniform_real_distribution<float>(-2.0f, static_cast<float>(world) + 2.0f)(rng);
  return p;
}

float random_max_t(std::mt19937& rng, int world) {
  switch (rng() % 5) {
    case 0: return 0.0f;
    case 1: return kInf;
    case 2: return 0.5f * static_cast<float>(rng() % (4 * world));
    default: return std::uniform_real_distribution<float>(0.0f, 2.0f * static_cast<float>(world))(rng);
  }
}

// A world edited step by step, mirrored in a map (the reference).
struct World {
  BroadPhase bp;
  std::map<Handle, Aabb> objects;
  std::vector<Handle> moving, statics;
  explicit World(std::uint32_t threads) : bp({.threads = threads}) {}
};

void random_step(World& w, std::mt19937& rng, int world, std::size_t target) {
  const auto add = [&](bool is_static) {
    std::vector<Aabb> boxes(1 + rng() % 4);
    for (Aabb& b : boxes) b = any_box(rng, world);
    const std::vector<Handle> h = w.bp.add(boxes, {.is_static = is_static});
    for (std::size_t i = 0; i < h.size(); ++i) {
      w.objects[h[i]] = boxes[i];
      (is_static ? w.statics : w.moving).push_back(h[i]);
    }
  };
  const auto remove_some = [&](std::vector<Handle>& from) {
    if (from.empty()) return;
    const std::size_t i = rng() % from.size();
    const Handle h = from[i];
    from.erase(from.begin() + static_cast<std::ptrdiff_t>(i));
    w.bp.remove(std::vector<Handle>{h});
    w.objects.erase(h);
  };
  if (w.objects.size() < target) add(rng() % 3 == 0);
  switch (rng() % 8) {
    case 0: add(false); break;
    case 1: add(true); break;
    case 2: remove_some(w.moving); break;
    case 3: remove_some(w.statics); break;
    default: break;
  }
  // Move a subset of the movers (nudged or teleported), now and then a static.
  std::vector<Handle> hs;
  std::vector<Aabb> bs;
  for (const Handle h : w.moving) {
    if (rng() % 3) continue;
    Aabb b = w.objects[h];
    if (rng() % 10 == 0) {
      b = any_box(rng, world);
    } else {
      const float s = 0.5f * static_cast<float>(static_cast<int>(rng() % 5) - 2);
      const int k = static_cast<int>(rng() % 3);
      b.min[k] += s;
      b.max[k] += s;
    }
    hs.push_back(h);
    bs.push_back(b);
  }
  if (!w.statics.empty() && rng() % 16 == 0) {
    const Handle h = w.statics[rng() % w.statics.size()];
    hs.push_back(h);
    bs.push_back(any_box(rng, world));
  }
  // move() takes any order; sort for the fast screen's common case half the time.
  if (rng() % 2) {
    std::vector<std::size_t> order(hs.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return hs[a] < hs[b]; });
    std::vector<Handle> h2;
    std::vector<Aabb> b2;
    for (const std::size_t i : order) h2.push_back(hs[i]), b2.push_back(bs[i]);
    hs.swap(h2);
    bs.swap(b2);
  }
  w.bp.move(hs, bs);
  for (std::size_t i = 0; i < hs.size(); ++i) w.objects[hs[i]] = bs[i];
  if (rng() % 2) w.bp.update();
}

void check_closest(const World& w, const Vec3f& o, const Vec3f& d, float max_t) {
  const std::vector<Hit> scan = scan_ray(w.objects, o, d, max_t);
  const std::optional<hbp::RayHit> got = w.bp.raycast_closest(o, d, max_t);
  const std::vector<Handle> all = w.bp.query_ray(o, d, max_t);
  if (scan.empty()) {
    ASSERT_FALSE(got.has_value());
    ASSERT_TRUE(all.empty());
    return;
  }
  const Hit best = *std::min_element(scan.begin(), scan.end());
  ASSERT_TRUE(got.has_value());
  ASSERT_EQ(got->handle, best.h);
  ASSERT_EQ(got->t, best.t);
  ASSERT_FALSE(all.empty());
  ASSERT_EQ(got->handle, all.front());
}

void check_cast(const World& w, const Aabb& box, const Vec3f& d, std::mt19937& rng) {
  const std::vector<Handle> want = handles_of(scan_cast(w.objects, box, d));
  ASSERT_EQ(w.bp.query_box_cast(box, d), want);
  std::vector<Handle> out = {7, 7, 7};
  ASSERT_EQ(w.bp.query_box_cast(box, d, out), want.size());
  ASSERT_EQ(out, want);
  // Visitor: stops after `stop` hits.
  const std::size_t stop = want.empty() ? 1 : 1 + rng() % want.size();
  std::vector<Handle> seen;
  const std::size_t calls = w.bp.query_box_cast(box, d, [&](Handle h) {
    seen.push_back(h);
    return seen.size() < stop;
  });
  ASSERT_EQ(calls, std::min(stop, want.size()));
  ASSERT_TRUE(std::equal(seen.begin(), seen.end(), want.begin()));
}

void run_sequence(std::uint32_t seed, int steps, int world, std::size_t target) {
  std::mt19937 rng(seed);
  World one(1), two(2);
  for (int step = 0; step < steps; ++step) {
    const std::uint32_t s = static_cast<std::uint32_t>(rng());
    std::mt19937 r1(s), r2(s);
    random_step(one, r1, world, target);
    random_step(two, r2, world, target);
    ASSERT_EQ(one.objects.size(), two.objects.size());
    ASSERT_TRUE(std::equal(one.objects.begin(), one.objects.end(), two.objects.begin(), [](const auto& a, const auto& b) {
      return a.first == b.first && std::memcmp(&a.second, &b.second, sizeof(Aabb)) == 0;
    }));
    for (int q = 0; q < 4; ++q) {
      Vec3f o = random_point(rng, world);
      if (rng() % 4 == 0 && !one.objects.empty()) {  // from inside (or on the face of) an object
        auto it = one.objects.begin();
        std::advance(it, static_cast<std::ptrdiff_t>(rng() % one.objects.size()));
        for (int k = 0; k < 3; ++k) o[k] = rng() % 2 ? it->second.min[k] : it->second.max[k];
      }
      const Vec3f d = random_direction(rng);
      const float max_t = random_max_t(rng, world);
      check_closest(one, o, d, max_t);
      check_closest(two, o, d, max_t);
      ASSERT_EQ(one.bp.raycast_closest(o, d, max_t).has_value(), two.bp.raycast_closest(o, d, max_t).has_value());

      const Aabb box = any_box(rng, world);
      Vec3f disp = random_direction(rng);
      const float scale = static_cast<float>(rng() % (2 * world + 1));
      for (float& c : disp) c *= scale;
      check_cast(one, box, disp, rng);
      check_cast(two, box, disp, rng);
      // Zero displacement: query_box's hits, at t = 0 (so in handle order).
      ASSERT_EQ(one.bp.query_box_cast(box, {0, 0, 0}), one.bp.query_box(box));
    }
    if (::testing::Test::HasFatalFailure()) return;
  }
}

}  // namespace

TEST(BroadPhaseQueries2, ClosestRayAndBoxCastMatchBruteForceOverLongSequences) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    run_sequence(seed, 1500, 12, 120);
    if (HasFatalFailure()) return;
  }
}

TEST(BroadPhaseQueries2, ClosestRayAndBoxCastMatchBruteForceInALargerWorld) {
  // Enough objects for trees several nodes deep, so the nearest-first walk
  // prunes whole subtrees.
  run_sequence(11, 400, 60, 3000);
}

TEST(BroadPhaseQueries2, ClosestRayPrunesButStaysExactOnManyTies) {
  // A lattice of identical-depth boxes: many hits share the entry t, the
  // smallest handle must win wherever it sits in the trees.
  BroadPhase bp({.threads = 1});
  std::map<Handle, Aabb> objects;
  std::vector<Aabb> boxes;
  for (int x = 0; x < 30; ++x)
    for (int y = 0; y < 30; ++y)
      for (int z = 0; z < 6; ++z)
        boxes.push_back({{float(x), float(y), float(2 * z)}, {float(x) + 1, float(y) + 1, float(2 * z) + 1}});
  std::vector<Handle> h = bp.add(std::span<const Aabb>(boxes.data(), boxes.size() / 2), {.is_static = true});
  std::vector<Handle> h2 = bp.add(std::span<const Aabb>(boxes.data() + boxes.size() / 2, boxes.size() / 2));
  h.insert(h.end(), h2.begin(), h2.end());
  for (std::size_t i = 0; i < h.size(); ++i) objects[h[i]] = boxes[i];
  std::mt19937 rng(5);
  for (int q = 0; q < 3000; ++q) {
    Vec3f o = {0.5f * float(rng() % 62), 0.5f * float(rng() % 62), -1.0f - float(rng() % 3)};
    Vec3f d = {0, 0, 1};
    if (q % 3 == 1) d = {0.5f * (float(rng() % 5) - 2), 0.5f * (float(rng() % 5) - 2), 1};
    if (q % 3 == 2) d = random_direction(rng);
    const float max_t = random_max_t(rng, 30);
    const std::vector<Hit> scan = scan_ray(objects, o, d, max_t);
    const std::optional<hbp::RayHit> got = bp.raycast_closest(o, d, max_t);
    ASSERT_EQ(got.has_value(), !scan.empty());
    if (!got) continue;
    const Hit best = *std::min_element(scan.begin(), scan.end());
    ASSERT_EQ(got->handle, best.h);
    ASSERT_EQ(got->t, best.t);
    ASSERT_EQ(bp.query_ray(o, d, max_t).front(), got->handle);
  }
}

TEST(BroadPhaseQueries2, BoxCastOnPowerOfTwoLatticeIsExact) {
  // Quarter-unit coordinates and displacements of 0 or +-2^k quarter units:
  // every grown bound and t is exact in float, so the float rule must
  // equal the rational one: the swept box touches the target iff the
  // intervals {t : t d_k in [T.min - B.max, T.max - B.min]} meet in [0, 1].
  std::mt19937 rng(9);
  BroadPhase bp({.threads = 2});
  std::map<Handle, Aabb> objects;
  const auto quarter_box = [&] {
    Aabb b;
    for (int k = 0; k < 3; ++k) {
      b.min[k] = 0.25f * float(rng() % 120);
      b.max[k] = b.min[k] + 0.25f * float(rng() % 12);
    }
    return b;
  };
  for (int i = 0; i < 1500; ++i) {
    const Aabb b = quarter_box();
    objects[bp.add(b, {.is_static = i % 2 == 0})] = b;
  }
  for (int q = 0; q < 3000; ++q) {
    const Aabb box = quarter_box();
    Vec3f d;
    int qd[3];  // displacement in quarter units
    for (int k = 0; k < 3; ++k) {
      const int mag = rng() % 4 == 0 ? 0 : 1 << (rng() % 8);
      qd[k] = rng() % 2 ? mag : -mag;
      d[k] = 0.25f * float(qd[k]);
    }
    std::vector<Handle> want;
    for (const auto& [h, b] : objects) {
      // t in [lo/qd, hi/qd] per axis (quarter units), as fractions num/den, den > 0.
      long lo_n = 0, lo_d = 1, hi_n = 1, hi_d = 1;  // [0, 1]
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        const long glo = std::lround(4 * (b.min[k] - box.max[k])), ghi = std::lround(4 * (b.max[k] - box.min[k]));
        if (qd[k] == 0) {
          ok = glo <= 0 && 0 <= ghi;
          continue;
        }
        long a = glo, c = ghi, den = qd[k];
        if (den < 0) a = -a, c = -c, den = -den, std::swap(a, c);
        if (a * lo_d > lo_n * den) lo_n = a, lo_d = den;  // max of lower ends
        if (c * hi_d < hi_n * den) hi_n = c, hi_d = den;  // min of upper ends
      }
      if (ok && lo_n * hi_d <= hi_n * lo_d) want.push_back(h);
    }
    std::vector<Handle> got = bp.query_box_cast(box, d);
    std::sort(got.begin(), got.end());
    ASSERT_EQ(got, want) << "cast " << q;
  }
}

TEST(BroadPhaseQueries2, EmptyAndErrors) {
  BroadPhase bp;
  EXPECT_FALSE(bp.raycast_closest({0, 0, 0}, {1, 0, 0}, kInf).has_value());
  EXPECT_TRUE(bp.query_box_cast({{0, 0, 0}, {1, 1, 1}}, {1, 0, 0}).empty());
  const Handle h = bp.add(Aabb{{2, 0, 0}, {3, 1, 1}});
  const std::optional<hbp::RayHit> hit = bp.raycast_closest({0, 0.5f, 0.5f}, {1, 0, 0}, 10);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->handle, h);
  EXPECT_EQ(hit->t, 2.0f);
  EXPECT_FALSE(bp.raycast_closest({0, 0.5f, 0.5f}, {1, 0, 0}, 1.99f).has_value());
  EXPECT_EQ(bp.raycast_closest({2.5f, 0.5f, 0.5f}, {1, 0, 0}, 0)->t, 0.0f);  // inside
  // The unit box cast 1 along x touches [2, 3] at t = 1 exactly, not before.
  EXPECT_EQ(bp.query_box_cast({{0, 0, 0}, {1, 1, 1}}, {1, 0, 0}), std::vector<Handle>{h});
  EXPECT_TRUE(bp.query_box_cast({{0, 0, 0}, {1, 1, 1}}, {0.99f, 0, 0}).empty());
  EXPECT_TRUE(bp.query_box_cast({{0, 1.5f, 0}, {1, 2, 1}}, {5, 0, 0}).empty());

  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto message = [](auto&& call) {
    try {
      call();
    } catch (const hbp::InvalidInput& e) {
      return std::string(e.what());
    }
    return std::string("no throw");
  };
  EXPECT_NE(message([&] { bp.raycast_closest({nan, 0, 0}, {1, 0, 0}, 1); }).find("raycast_closest: origin[0]"),
            std::string::npos);
  EXPECT_NE(message([&] { bp.raycast_closest({0, 0, 0}, {1, kInf, 0}, 1); }).find("direction[1]"), std::string::npos);
  EXPECT_NE(message([&] { bp.raycast_closest({0, 0, 0}, {1, 0, 0}, -1); }).find("max_t"), std::string::npos);
  EXPECT_NE(message([&] { bp.raycast_closest({0, 0, 0}, {1, 0, 0}, nan); }).find("max_t"), std::string::npos);
  EXPECT_NE(message([&] { bp.query_box_cast({{1, 0, 0}, {0, 1, 1}}, {1, 0, 0}); }).find("query_box_cast: box"),
            std::string::npos);
  EXPECT_NE(message([&] { bp.query_box_cast({{0, 0, 0}, {1, 1, 1}}, {0, 0, nan}); }).find("displacement[2]"),
            std::string::npos);
  std::vector<Handle> out;
  EXPECT_NE(message([&] { bp.query_box_cast({{0, 0, 0}, {1, 1, 1}}, {kInf, 0, 0}, out); }).find("displacement[0]"),
            std::string::npos);
}
