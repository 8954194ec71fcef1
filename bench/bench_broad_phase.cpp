// SPDX-License-Identifier: MIT
// hbp::BroadPhase measured beside btDbvtBroadphase and the whole-frame
// HybridBroadPhase, each pair of systems on the same boxes in the same run:
//
//   MostlyStatic/<statics>/<moving>/<threads>: a world of the paper's density,
//     `statics` static boxes plus `moving` boxes moving as in the paper
//     scenario. Per frame: move() + update() beside DBVT's setAabb of the
//     moving proxies + calculateOverlappingPairs (statics in DBVT's
//     StaticFilter group, so neither side reports static/static pairs). Every
//     timed frame both report the same exact pairs (Bullet's cache filtered
//     by the closed-box test), or the benchmark fails.
//   AllMoving/<n>/<threads>: the paper scene, every object moving through
//     move() + update(), beside HybridBroadPhase::update(BoxArray) on the
//     same frames (same pairs checked each frame). With 1 thread the
//     calling thread's CPU time is all the work of each side: the
//     *_cpu_* counters (not another process's time slices; memory-bound stages
//     still take longer when the other cores load the memory bus).
//   DoublePrecision/<n>/<threads>/<exact>: the paper scene through a float
//     BroadPhase (move + update of float boxes) and a double_precision one
//     (move + update of the same boxes as AabbD) on the same frames:
//     update() alone and move + update, medians of both and their ratio.
//     exact = 1: the doubles are the float coordinates (every float box
//     exact: the confirmation is a flag test; pairs checked equal each
//     frame); exact = 0: every coordinate moved by 2^-30 (no float box
//     exact: every candidate pair goes through the double test).
//   SleepingWorld/<n>/<threads>: the MostlyStatic world with its n / 100
//     moving objects spread over the handles (every 100th object), built two
//     ways: all n added moving, then 99 % put to sleep with set_static
//     ("slept"), and the same objects added static or moving from the start
//     in the same handle order ("built"). Per frame both move their movers
//     and update (same pairs checked); the slept world's steady frame
//     against the built one's.
//   Snapshot/<n>/<moving %>: snapshot() and restore() of a world of n paper
//     objects (1 %: the SleepingWorld world; 100 %: all moving), and the
//     first update() after a restore (it rebuilds the derived structures).
//     Medians, and the first call apart: it takes fresh pages from the
//     kernel, the later ones mostly reuse the allocator's.
//   BoxQueries/<n>, RayQueries/<n>: one thread, the paper frame of n objects
//     as static objects; boxes of the objects' sizes, rays of 500 m; beside
//     btDbvtBroadphase::aabbTest / rayTest on the same boxes (answers checked
//     against a brute-force scan on a sample, and contained in DBVT's).
//   ClosestRays/<n>, BoxCasts/<n>: the same static frame in a
//     btCollisionWorld (one btBoxShape object per box): raycast_closest
//     beside rayTest with a ClosestRayResultCallback on the same 500 m rays,
//     and query_box_cast (every hit, sorted) beside convexSweepTest of a
//     btBoxShape with a ClosestConvexResultCallback on the same boxes and
//     20 m displacements (answers checked against a scan on a sample; how
//     often Bullet's closest object is ours is reported).
//
// Times are wall clock (the manual time is ours; counters give both sides'
// medians and worst frames and the ratio).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <utility>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "hbp/bullet/bullet_headers.hpp"
#include "baselines/bullet_pairs.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/scenario.hpp"
#include "pipeline/box_cast.hpp"
#include "pipeline/ray_segment.hpp"
#include "support/clock.hpp"
#include "support/percentile.hpp"
#include "support/random.hpp"

namespace {

using hbp::median;
using hbp::ms_since;
using hbp::SteadyClock;
using hbp::thread_cpu_ms;

using hbp::Aabb;
using hbp::BoxArray;
using hbp::Handle;
using hbp::Pair;

// Wall and calling-thread CPU milliseconds of one run of f (the CPU time is
// all of f's work when it runs on the calling thread alone).
struct Millis {
  double wall = 0, cpu = 0;
};
template <class F>
Millis time_ms(F&& f) {
  const auto t0 = SteadyClock::now();
  const double c0 = thread_cpu_ms();
  f();
  return {ms_since(t0), thread_cpu_ms() - c0};
}

// Runs a and b in turn, a first when a_first: a benchmark alternates the
// order each frame so that neither side always gets the warm cache.
template <class A, class B>
void in_turn(bool a_first, A&& a, B&& b) {
  if (a_first) {
    a();
    b();
  } else {
    b();
    a();
  }
}

double worst(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

// Two sides' per-frame times as counters: <a>_median_ms, <b>_median_ms and
// `ratio` = median(a) / median(b); with worst, <a>_worst_ms and <b>_worst_ms.
void side_counters(benchmark::State& state, const std::string& a, const std::vector<double>& a_ms, const std::string& b,
                   const std::vector<double>& b_ms, const std::string& ratio, bool with_worst) {
  state.counters[a + "_median_ms"] = median(a_ms);
  state.counters[b + "_median_ms"] = median(b_ms);
  state.counters[ratio] = median(a_ms) / median(b_ms);
  if (with_worst) {
    state.counters[a + "_worst_ms"] = worst(a_ms);
    state.counters[b + "_worst_ms"] = worst(b_ms);
  }
}

void to_aabbs(const BoxArray& b, std::vector<Aabb>& out) {
  out.resize(b.size());
  for (std::size_t i = 0; i < b.size(); ++i) out[i] = b.get(i);
}

// The paper's frame of n objects (density: 5 * 50^3 m^3 per object).
BoxArray paper_frame(std::uint32_t n, std::uint64_t seed) {
  hbp::ScenarioParams p;
  p.n = n;
  p.seed = seed;
  hbp::Scenario s(p);
  BoxArray boxes;
  s.compute_boxes(boxes);
  return boxes;
}

// `moving` objects of the paper scenario in the world of statics + moving
// objects at the paper's density.
hbp::Scenario moving_scenario(std::uint32_t statics, std::uint32_t moving) {
  hbp::ScenarioParams p;
  p.n = moving;
  p.seed = 7;
  p.volume_per_object *= static_cast<double>(statics + moving) / moving;  // same world side
  return hbp::Scenario(p);
}

void MostlyStatic(benchmark::State& state) {
  const auto statics = static_cast<std::uint32_t>(state.range(0));
  const auto moving = static_cast<std::uint32_t>(state.range(1));
  const auto threads = static_cast<unsigned>(state.range(2));
  const bool with_dbvt = state.range(3) != 0;  // 0: ours alone (profiling)
  BoxArray all = paper_frame(statics + moving, 0);  // first `statics` boxes are the statics
  hbp::Scenario mover = moving_scenario(statics, moving);
  BoxArray moving_boxes;
  mover.compute_boxes(moving_boxes);
  for (std::uint32_t i = 0; i < moving; ++i) all.set(statics + i, moving_boxes.get(i));

  // Ours: statics first, so handle == object index.
  hbp::BroadPhase bp({.threads = threads});
  std::vector<Aabb> aabbs;
  to_aabbs(all, aabbs);
  const auto hs = bp.add(std::span<const Aabb>(aabbs).first(statics), {.is_static = true});
  const auto hm = bp.add(std::span<const Aabb>(aabbs).subspan(statics));
  if (hs.back() != statics - 1 || hm.back() != statics + moving - 1) throw std::logic_error("handle != index");
  bp.update();

  // DBVT: statics in the static group (never paired with each other).
  btDbvtBroadphase dbvt;
  std::vector<btBroadphaseProxy*> proxies(statics + moving);
  for (std::uint32_t i = 0; with_dbvt && i < statics + moving; ++i) {
    const bool is_static = i < statics;
    proxies[i] = dbvt.createProxy(hbp::baselines::bullet_min(all, i), hbp::baselines::bullet_max(all, i),
                                  BOX_SHAPE_PROXYTYPE, hbp::baselines::bullet_user_pointer(i),
                                  is_static ? btBroadphaseProxy::StaticFilter : btBroadphaseProxy::DefaultFilter,
                                  is_static ? btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter
                                            : btBroadphaseProxy::AllFilter,
                                  nullptr);
  }
  // Warm-up: DBVT moves the unmoved proxies to its fixed tree over 2 frames.
  std::vector<Pair> bullet_exact;
  std::vector<Aabb> moved(moving);
  std::vector<double> ours_ms, dbvt_ms, update_ms, move_ms, update_cpu_ms;
  std::uint64_t pairs = 0;
  int frame = 0;
  auto step = [&] {
    mover.step();
    mover.compute_boxes(moving_boxes);
    for (std::uint32_t i = 0; i < moving; ++i) {
      moved[i] = moving_boxes.get(i);
      all.set(statics + i, moved[i]);
    }
  };
  auto run_frame = [&](bool timed) {
    step();
    // Let the scenario's TBB workers go idle (they spin a while after a
    // parallel loop, taking a core from the timed code).
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    auto t0 = SteadyClock::now();
    bp.move(hm, moved);
    move_ms.push_back(ms_since(t0));
    const double cpu0 = thread_cpu_ms();
    const hbp::BroadPhaseUpdate& u = bp.update();
    update_cpu_ms.push_back(thread_cpu_ms() - cpu0);
    const double ours = ms_since(t0);
    update_ms.push_back(bp.stats().wall_ms);
    if (!with_dbvt) return ours;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // same for DBVT after our workers
    t0 = SteadyClock::now();
    for (std::uint32_t i = 0; i < moving; ++i)
      dbvt.setAabb(proxies[statics + i], hbp::baselines::bullet_min(all, statics + i),
                   hbp::baselines::bullet_max(all, statics + i), nullptr);
    dbvt.calculateOverlappingPairs(nullptr);
    const double theirs = ms_since(t0);
    hbp::baselines::exact_bullet_pairs(*dbvt.getOverlappingPairCache(), all, bullet_exact);
    if (bullet_exact != u.pairs)
      throw std::runtime_error("frame " + std::to_string(frame) + ": BroadPhase " + std::to_string(u.pairs.size()) +
                               " pairs, DBVT exact " + std::to_string(bullet_exact.size()));
    ++frame;
    if (timed) {
      ours_ms.push_back(ours);  // move() + update()
      dbvt_ms.push_back(theirs);
      pairs = u.pairs.size();
    }
    return ours;
  };
  for (int w = 0; w < 3; ++w) run_frame(false);
  // DBVT at its best: both trees rebuilt top-down once the statics settled
  // in the fixed tree (an engine would not, but it only helps DBVT).
  if (with_dbvt) dbvt.optimize();
  run_frame(false);
  update_ms.clear();
  move_ms.clear();
  update_cpu_ms.clear();
  for (auto _ : state) {
    const double ours = run_frame(true);
    if (!with_dbvt) ours_ms.push_back(ours);
    state.SetIterationTime(ours / 1000.0);
  }
  state.counters["update_median_ms"] = median(update_ms);
  state.counters["move_median_ms"] = median(move_ms);
  state.counters["update_thread_cpu_median_ms"] = median(update_cpu_ms);
  side_counters(state, "dbvt", dbvt_ms, "ours", ours_ms, "speedup_vs_dbvt", true);
  state.counters["pairs"] = static_cast<double>(pairs);
  // No destroyProxy: with the pair cache's linear removal that costs minutes
  // at 10^6 proxies; the broad phase's destructor frees its trees and cache.
}

void AllMoving(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  hbp::ScenarioParams p;
  p.n = n;
  hbp::Scenario scenario(p);
  BoxArray boxes;
  scenario.compute_boxes(boxes);
  std::vector<Aabb> aabbs;
  to_aabbs(boxes, aabbs);
  hbp::BroadPhase bp({.threads = threads});
  hbp::HybridBroadPhase whole({.threads = threads});
  const auto h = bp.add(aabbs);
  bp.update();
  whole.update(boxes);
  std::vector<double> ours_ms, whole_ms, ours_cpu_ms, whole_cpu_ms;
  std::uint64_t pairs = 0;
  auto run_frame = [&](bool timed) {
    scenario.step();
    scenario.compute_boxes(boxes);
    to_aabbs(boxes, aabbs);
    Millis ours, theirs;
    in_turn(
        ours_ms.size() % 2 == 0,
        [&] {
          ours = time_ms([&] {
            bp.move(h, aabbs);
            bp.update();
          });
        },
        [&] { theirs = time_ms([&] { whole.update(boxes); }); });
    if (bp.last_update().pairs != whole.pairs()) throw std::runtime_error("BroadPhase and HybridBroadPhase differ");
    if (timed) {
      ours_ms.push_back(ours.wall);
      whole_ms.push_back(theirs.wall);
      ours_cpu_ms.push_back(ours.cpu);
      whole_cpu_ms.push_back(theirs.cpu);
      pairs = whole.pairs().size();
    }
    return ours.wall;
  };
  run_frame(false);
  for (auto _ : state) state.SetIterationTime(run_frame(true) / 1000.0);
  side_counters(state, "ours", ours_ms, "whole_frame", whole_ms, "ours_over_whole_frame", true);
  if (threads == 1)  // the calling thread does all the work: its CPU time is all of it
    side_counters(state, "ours_cpu", ours_cpu_ms, "whole_frame_cpu", whole_cpu_ms, "ours_cpu_over_whole_frame", false);
  state.counters["pairs"] = static_cast<double>(pairs);
}

void DoublePrecision(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  const bool exact = state.range(2) != 0;
  hbp::ScenarioParams p;
  p.n = n;
  hbp::Scenario scenario(p);
  BoxArray boxes;
  std::vector<Aabb> aabbs;
  std::vector<hbp::AabbD> doubles;
  const double nudge = exact ? 0.0 : std::ldexp(1.0, -30);
  const auto next_frame = [&] {
    scenario.compute_boxes(boxes);
    to_aabbs(boxes, aabbs);
    doubles.resize(aabbs.size());
    for (std::size_t i = 0; i < aabbs.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        doubles[i].min[k] = static_cast<double>(aabbs[i].min[k]) + nudge;
        doubles[i].max[k] = static_cast<double>(aabbs[i].max[k]) + nudge;
      }
  };
  next_frame();
  hbp::BroadPhase single({.threads = threads});
  hbp::BroadPhase dbl({.threads = threads, .double_precision = true});
  const auto hs = single.add(aabbs);
  const auto hd = dbl.add(doubles);
  single.update();
  dbl.update();
  std::vector<double> float_update, double_update, float_frame, double_frame, float_cpu, double_cpu;
  std::uint64_t pairs = 0;
  auto run_frame = [&](bool timed) {
    scenario.step();
    next_frame();
    // update() alone (wall and CPU) inside move() + update() (wall).
    Millis fu, du, ff, df;
    in_turn(
        float_update.size() % 2 == 0,
        [&] {
          ff = time_ms([&] {
            single.move(hs, aabbs);
            fu = time_ms([&] { single.update(); });
          });
        },
        [&] {
          df = time_ms([&] {
            dbl.move(hd, doubles);
            du = time_ms([&] { dbl.update(); });
          });
        });
    if (exact && dbl.last_update().pairs != single.last_update().pairs)
      throw std::runtime_error("double and float BroadPhase differ on float-exact boxes");
    if (timed) {
      float_update.push_back(fu.wall);
      double_update.push_back(du.wall);
      float_frame.push_back(ff.wall);
      double_frame.push_back(df.wall);
      float_cpu.push_back(fu.cpu);
      double_cpu.push_back(du.cpu);
      pairs = dbl.last_update().pairs.size();
    }
    return du.wall;
  };
  run_frame(false);
  for (auto _ : state) state.SetIterationTime(run_frame(true) / 1000.0);
  side_counters(state, "double_update", double_update, "float_update", float_update, "double_over_float_update", false);
  side_counters(state, "double_move_update", double_frame, "float_move_update", float_frame,
                "double_over_float_move_update", false);
  if (threads == 1)  // the calling thread does all the work: its CPU time is all of it
    side_counters(state, "double_update_cpu", double_cpu, "float_update_cpu", float_cpu, "double_over_float_update_cpu",
                  false);
  state.counters["pairs"] = static_cast<double>(pairs);
}

// The SleepingWorld / Snapshot world: the paper frame of n objects, the
// movers (every 100th object) from the mover scenario of MostlyStatic.
struct SleepScene {
  std::uint32_t n, moving;
  BoxArray all;
  hbp::Scenario mover;
  BoxArray mover_boxes;
  std::vector<Aabb> aabbs, moved;
  std::vector<Handle> movers, sleepers;  // handles = object indices in both worlds

  explicit SleepScene(std::uint32_t objects)
      : n(objects), moving(objects / 100), all(paper_frame(objects, 0)), mover(moving_scenario(n - moving, moving)) {
    mover.compute_boxes(mover_boxes);
    for (std::uint32_t k = 0; k < moving; ++k) all.set(100 * k, mover_boxes.get(k));
    to_aabbs(all, aabbs);
    for (std::uint32_t i = 0; i < n; ++i) (is_mover(i) ? movers : sleepers).push_back(i);
    moved.resize(moving);
  }
  static bool is_mover(std::uint32_t i) { return i % 100 == 0; }
  void step() {
    mover.step();
    mover.compute_boxes(mover_boxes);
    for (std::uint32_t k = 0; k < moving; ++k) moved[k] = mover_boxes.get(k);
  }
  // Added moving, then 99 % put to sleep.
  void slept(hbp::BroadPhase& bp) const {
    if (bp.add(aabbs).back() != n - 1) throw std::logic_error("handle != index");
    bp.update();
    bp.set_static(sleepers, true);
    bp.update();
  }
  // Each object added with its kind, in index order (runs of one kind).
  void built(hbp::BroadPhase& bp) const {
    for (std::uint32_t b = 0; b < n;) {
      std::uint32_t e = b + 1;
      while (e < n && is_mover(e) == is_mover(b)) ++e;
      const auto h = bp.add(std::span<const Aabb>(aabbs).subspan(b, e - b), {.is_static = !is_mover(b)});
      if (h.back() != e - 1) throw std::logic_error("handle != index");
      b = e;
    }
    bp.update();
  }
};

void SleepingWorld(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  SleepScene scene(n);
  hbp::BroadPhase slept({.threads = threads}), built({.threads = threads});
  scene.slept(slept);
  scene.built(built);
  if (slept.stats().statics != built.stats().statics) throw std::logic_error("not the same world");
  std::vector<double> slept_ms, built_ms;
  std::uint64_t pairs = 0;
  auto run_frame = [&](bool timed) {
    scene.step();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // the scenario's workers go idle
    double t[2];
    const auto frame_of = [&](hbp::BroadPhase& bp, double& ms) {
      const auto t0 = SteadyClock::now();
      bp.move(scene.movers, scene.moved);
      bp.update();
      ms = ms_since(t0);
    };
    in_turn(
        slept_ms.size() % 2 == 0, [&] { frame_of(slept, t[0]); }, [&] { frame_of(built, t[1]); });
    if (slept.last_update().pairs != built.last_update().pairs) throw std::runtime_error("slept and built differ");
    if (timed) {
      slept_ms.push_back(t[0]);
      built_ms.push_back(t[1]);
      pairs = slept.last_update().pairs.size();
    }
    return t[0];
  };
  for (int w = 0; w < 3; ++w) run_frame(false);
  for (auto _ : state) state.SetIterationTime(run_frame(true) / 1000.0);
  side_counters(state, "slept", slept_ms, "built", built_ms, "slept_over_built", true);
  state.counters["pairs"] = static_cast<double>(pairs);
}

void Snapshot(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const bool all_moving = state.range(1) == 100;
  hbp::BroadPhase bp({.threads = 2}), target({.threads = 2});
  SleepScene scene(n);
  if (all_moving) {
    bp.add(scene.aabbs);
    bp.update();
  } else {
    scene.built(bp);
  }
  scene.step();
  bp.move(scene.movers, scene.moved);
  bp.update();  // a frame with events, then a pending edit
  scene.step();
  bp.move(scene.movers, scene.moved);
  // Both are single-threaded: the calling thread's CPU time is all their
  // work (page faults included), whatever else the machine runs.
  std::vector<double> snapshot_ms, restore_ms, update_ms, snapshot_cpu_ms, restore_cpu_ms;
  std::size_t bytes = 0;
  for (auto _ : state) {
    std::vector<std::byte> data;
    const Millis snap = time_ms([&] { data = bp.snapshot(); });
    snapshot_ms.push_back(snap.wall);
    snapshot_cpu_ms.push_back(snap.cpu);
    const Millis restore = time_ms([&] { target.restore(data); });
    restore_ms.push_back(restore.wall);
    restore_cpu_ms.push_back(restore.cpu);
    update_ms.push_back(time_ms([&] { target.update(); }).wall);
    bytes = data.size();
    state.SetIterationTime((snapshot_ms.back() + restore_ms.back()) / 1000.0);
  }
  const std::vector<Pair> expect = bp.update().pairs;
  if (target.last_update().pairs != expect) throw std::runtime_error("restored world differs");
  state.counters["snapshot_median_ms"] = median(snapshot_ms);
  state.counters["restore_median_ms"] = median(restore_ms);
  state.counters["snapshot_cpu_median_ms"] = median(snapshot_cpu_ms);
  // The first call gets its memory fresh from the kernel (page faults); the
  // later ones mostly reuse what the allocator kept.
  state.counters["snapshot_first_ms"] = snapshot_ms.front();
  state.counters["restore_first_ms"] = restore_ms.front();
  state.counters["restore_cpu_median_ms"] = median(restore_cpu_ms);
  state.counters["first_update_after_restore_median_ms"] = median(update_ms);
  state.counters["snapshot_MB"] = static_cast<double>(bytes) / 1e6;
  state.counters["pairs"] = static_cast<double>(expect.size());
}

// The side of the paper's world of n objects.
float paper_side(std::uint32_t n) {
  hbp::ScenarioParams p;
  p.n = n;
  return static_cast<float>(p.world_side());
}

// Every box added as a static object (handle = index).
void add_static(hbp::BroadPhase& bp, const BoxArray& boxes) {
  std::vector<Aabb> aabbs;
  to_aabbs(boxes, aabbs);
  bp.add(aabbs, {.is_static = true});
}

// A paper frame loaded into both systems, for queries.
struct QueryWorld {
  BoxArray boxes;
  hbp::BroadPhase bp{{.threads = 1}};
  btDbvtBroadphase dbvt;
  std::vector<btBroadphaseProxy*> proxies;
  float side = 0;

  explicit QueryWorld(std::uint32_t n) : boxes(paper_frame(n, 0)), side(paper_side(n)) {
    add_static(bp, boxes);
    proxies.resize(n);
    for (std::uint32_t i = 0; i < n; ++i)
      proxies[i] = dbvt.createProxy(hbp::baselines::bullet_min(boxes, i), hbp::baselines::bullet_max(boxes, i),
                                    BOX_SHAPE_PROXYTYPE, hbp::baselines::bullet_user_pointer(i),
                                    btBroadphaseProxy::StaticFilter,
                                    btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter, nullptr);
    for (int f = 0; f < 3; ++f) dbvt.calculateOverlappingPairs(nullptr);
  }
};

struct Collect : btBroadphaseAabbCallback {
  std::vector<std::uint32_t> ids;
  bool process(const btBroadphaseProxy* p) override {
    ids.push_back(hbp::baselines::bullet_object_index(p->m_clientObject));
    return true;
  }
};

struct RayCollect : btBroadphaseRayCallback {
  std::vector<std::uint32_t> ids;
  RayCollect(const btVector3& from, const btVector3& to) {
    btVector3 dir = to - from;
    dir.normalize();
    for (int k = 0; k < 3; ++k) m_rayDirectionInverse[k] = dir[k] == 0 ? btScalar(BT_LARGE_FLOAT) : 1 / dir[k];
    m_signs[0] = m_rayDirectionInverse[0] < 0;
    m_signs[1] = m_rayDirectionInverse[1] < 0;
    m_signs[2] = m_rayDirectionInverse[2] < 0;
    m_lambda_max = dir.dot(to - from);
  }
  bool process(const btBroadphaseProxy* p) override {
    ids.push_back(hbp::baselines::bullet_object_index(p->m_clientObject));
    return true;
  }
};

constexpr int kQueries = 20000;
constexpr int kChecked = 100;  // brute-force checked per run

// A query benchmark's world of n objects, built once and kept between runs
// (and iterations) of the benchmarks that use that kind of world.
template <class World>
World& kept_world(std::uint32_t n) {
  static World* world = nullptr;
  if (!world || world->boxes.size() != n) {
    delete world;
    world = new World(n);
  }
  return *world;
}

// Random rays inside the world: unit direction, origins uniform in the world.
struct Ray {
  float o[3], d[3];
};
std::vector<Ray> random_rays(float side, std::uint64_t seed) {
  hbp::Random rng(seed);
  std::vector<Ray> rays(kQueries);
  for (Ray& r : rays) {
    float len = 0;
    do {
      for (int k = 0; k < 3; ++k) r.d[k] = static_cast<float>(rng.uniform(-1, 1));
      len = std::sqrt(r.d[0] * r.d[0] + r.d[1] * r.d[1] + r.d[2] * r.d[2]);
    } while (len < 0.1f || len > 1);
    for (int k = 0; k < 3; ++k) {
      r.d[k] /= len;
      r.o[k] = static_cast<float>(rng.uniform(0, side));
    }
  }
  return rays;
}

// A ray's ends for Bullet: origin and origin + length * direction.
btVector3 bullet_from(const Ray& r) { return btVector3(r.o[0], r.o[1], r.o[2]); }
btVector3 bullet_to(const Ray& r, float length) {
  return bullet_from(r) + length * btVector3(r.d[0], r.d[1], r.d[2]);
}

// Every box of `boxes` that hits(min, max, t) accepts, as (t, object index)
// sorted: the brute-force answer of a ray or a cast, in the query's order.
template <class Hits>
std::vector<std::pair<float, Handle>> scan_hits(const BoxArray& boxes, const Hits& hits) {
  std::vector<std::pair<float, Handle>> want;
  for (std::uint32_t k = 0; k < boxes.size(); ++k) {
    const Aabb b = boxes.get(k);
    float t;
    if (hits(b.min, b.max, t)) want.emplace_back(t, k);
  }
  std::sort(want.begin(), want.end());
  return want;
}
std::vector<Handle> handles_of(const std::vector<std::pair<float, Handle>>& hits) {
  std::vector<Handle> h;
  for (const auto& x : hits) h.push_back(x.second);
  return h;
}

// Wall and calling-thread CPU seconds of one run of f.
struct Seconds {
  double wall = 0, cpu = 0;
};
template <class F>
Seconds time_run(F&& f) {
  const Millis ms = time_ms(std::forward<F>(f));
  return {ms.wall / 1000, ms.cpu / 1000};
}

// ours_<what>_per_s, dbvt_<what>_per_s and the same per CPU second.
void rate_counters(benchmark::State& state, const std::string& what, Seconds ours, Seconds dbvt) {
  state.counters["ours_" + what + "_per_s"] = kQueries / ours.wall;
  state.counters["dbvt_" + what + "_per_s"] = kQueries / dbvt.wall;
  state.counters["ours_" + what + "_per_cpu_s"] = kQueries / ours.cpu;
  state.counters["dbvt_" + what + "_per_cpu_s"] = kQueries / dbvt.cpu;
}

void BoxQueries(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  QueryWorld& w = kept_world<QueryWorld>(n);
  // Boxes of the objects' sizes: object boxes moved to random places.
  hbp::Random rng(3);
  std::vector<Aabb> queries(kQueries);
  for (Aabb& q : queries) {
    const Aabb o = w.boxes.get(rng.below(static_cast<std::uint32_t>(n)));
    for (int k = 0; k < 3; ++k) {
      const auto c = static_cast<float>(rng.uniform(0, w.side));
      const float half = 0.5f * (o.max[k] - o.min[k]);
      q.min[k] = c - half;
      q.max[k] = c + half;
    }
  }
  std::uint64_t hits = 0, dbvt_hits = 0;
  Seconds ours, dbvt;
  for (auto _ : state) {
    ours = time_run([&] {
      hits = 0;
      for (const Aabb& q : queries) hits += w.bp.query_box(q).size();
    });
    dbvt = time_run([&] {
      Collect c;
      for (const Aabb& q : queries) {
        c.ids.clear();
        w.dbvt.aabbTest(btVector3(q.min[0], q.min[1], q.min[2]), btVector3(q.max[0], q.max[1], q.max[2]), c);
        dbvt_hits += c.ids.size();
      }
    });
    state.SetIterationTime(ours.wall);
  }
  // Checked against a scan and against DBVT's (superset) answer.
  for (int i = 0; i < kChecked; ++i) {
    const Aabb& q = queries[static_cast<std::size_t>(i)];
    std::vector<Handle> want;
    for (std::uint32_t k = 0; k < n; ++k)
      if (hbp::overlaps(w.boxes.get(k), q)) want.push_back(k);
    if (w.bp.query_box(q) != want) throw std::runtime_error("box query " + std::to_string(i) + " differs from brute force");
    Collect c;
    w.dbvt.aabbTest(btVector3(q.min[0], q.min[1], q.min[2]), btVector3(q.max[0], q.max[1], q.max[2]), c);
    std::sort(c.ids.begin(), c.ids.end());
    if (!std::includes(c.ids.begin(), c.ids.end(), want.begin(), want.end()))
      throw std::runtime_error("DBVT misses a box hit");
  }
  rate_counters(state, "queries", ours, dbvt);
  state.counters["hits_per_query"] = static_cast<double>(hits) / kQueries;
  state.SetItemsProcessed(state.iterations() * kQueries);
}

void RayQueries(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  QueryWorld& w = kept_world<QueryWorld>(n);
  // Random rays of 500 m inside the world: unit direction, max_t = 500.
  const std::vector<Ray> rays = random_rays(w.side, 4);
  constexpr float kLength = 500;
  std::uint64_t hits = 0;
  Seconds ours, dbvt;
  for (auto _ : state) {
    ours = time_run([&] {
      hits = 0;
      for (const Ray& r : rays) hits += w.bp.query_ray(r.o, r.d, kLength).size();
    });
    dbvt = time_run([&] {
      for (const Ray& r : rays) {
        RayCollect c(bullet_from(r), bullet_to(r, kLength));
        w.dbvt.rayTest(bullet_from(r), bullet_to(r, kLength), c);
      }
    });
    state.SetIterationTime(ours.wall);
  }
  // Checked against a scan (same slab test) and against DBVT's answer.
  std::uint64_t dbvt_missed = 0;
  for (int i = 0; i < kChecked; ++i) {
    const Ray& r = rays[static_cast<std::size_t>(i)];
    const hbp::detail::RaySegment seg(r.o, r.d, kLength);
    std::vector<Handle> want_h = handles_of(scan_hits(w.boxes, [&](const float* lo, const float* hi, float& t) {
      return seg.hits(lo, hi, t);
    }));
    if (w.bp.query_ray(r.o, r.d, kLength) != want_h)
      throw std::runtime_error("ray " + std::to_string(i) + " differs from brute force");
    RayCollect c(bullet_from(r), bullet_to(r, kLength));
    w.dbvt.rayTest(bullet_from(r), bullet_to(r, kLength), c);
    std::sort(c.ids.begin(), c.ids.end());
    std::sort(want_h.begin(), want_h.end());
    for (Handle h : want_h) dbvt_missed += std::binary_search(c.ids.begin(), c.ids.end(), h) ? 0 : 1;
  }
  state.counters["dbvt_missed_in_check"] = static_cast<double>(dbvt_missed);
  rate_counters(state, "rays", ours, dbvt);
  state.counters["hits_per_ray"] = static_cast<double>(hits) / kQueries;
  state.SetItemsProcessed(state.iterations() * kQueries);
}

// The query frame as a btCollisionWorld of static box objects (object i's
// user index is i), built once beside the QueryWorld.
struct BulletQueryWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btCollisionWorld world{&dispatcher, &broadphase, &config};
  std::vector<std::unique_ptr<btBoxShape>> shapes;
  std::vector<std::unique_ptr<btCollisionObject>> objects;

  explicit BulletQueryWorld(const BoxArray& boxes) {
    const std::size_t n = boxes.size();
    shapes.reserve(n);
    objects.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Aabb b = boxes.get(i);
      const btVector3 lo(b.min[0], b.min[1], b.min[2]), hi(b.max[0], b.max[1], b.max[2]);
      shapes.push_back(std::make_unique<btBoxShape>(0.5f * (hi - lo)));
      auto o = std::make_unique<btCollisionObject>();
      o->setCollisionShape(shapes.back().get());
      o->setWorldTransform(btTransform(btQuaternion::getIdentity(), 0.5f * (lo + hi)));
      o->setCollisionFlags(btCollisionObject::CF_STATIC_OBJECT);
      o->setUserIndex(static_cast<int>(i));
      world.addCollisionObject(o.get(), btBroadphaseProxy::StaticFilter,
                               btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter);
      objects.push_back(std::move(o));
    }
    world.updateAabbs();
  }
};

// The paper frame as static objects of a BroadPhase and of a
// btCollisionWorld, built once and kept between runs.
struct CastWorld {
  BoxArray boxes;
  hbp::BroadPhase bp{{.threads = 1}};
  BulletQueryWorld bullet;
  float side = 0;

  explicit CastWorld(std::uint32_t n) : boxes(paper_frame(n, 0)), bullet(boxes), side(paper_side(n)) {
    add_static(bp, boxes);
  }
};

// The median run of several (by CPU time, the wall time of that run with it).
Seconds median_run(std::vector<Seconds> runs) {
  std::sort(runs.begin(), runs.end(), [](const Seconds& a, const Seconds& b) { return a.cpu < b.cpu; });
  return runs[runs.size() / 2];
}

// Bullet's rates beside ours, medians of the iterations: <what>_per_s for each side.
void bullet_rate_counters(benchmark::State& state, const std::string& what, const std::vector<Seconds>& ours_runs,
                          const std::vector<Seconds>& bullet_runs) {
  const Seconds ours = median_run(ours_runs), bullet = median_run(bullet_runs);
  state.counters["ours_" + what + "_per_s"] = kQueries / ours.wall;
  state.counters["bullet_" + what + "_per_s"] = kQueries / bullet.wall;
  state.counters["ours_" + what + "_per_cpu_s"] = kQueries / ours.cpu;
  state.counters["bullet_" + what + "_per_cpu_s"] = kQueries / bullet.cpu;
  state.counters["ratio_per_cpu_s"] = bullet.cpu / ours.cpu;
}

void ClosestRays(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  CastWorld& w = kept_world<CastWorld>(n);
  BulletQueryWorld& bw = w.bullet;
  const std::vector<Ray> rays = random_rays(w.side, 4);
  constexpr float kLength = 500;
  std::uint64_t found = 0, bullet_found = 0;
  std::vector<Seconds> ours_runs, bullet_runs, all_hits_runs, closest_inf_runs, all_hits_inf_runs;
  std::uint64_t inf_hits = 0;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  w.bp.raycast_closest({0, 0, 0}, {1, 0, 0}, 1);  // builds the tree: not timed
  for (auto _ : state) {
    const Seconds ours = time_run([&] {
      found = 0;
      for (const Ray& r : rays) found += w.bp.raycast_closest({r.o[0], r.o[1], r.o[2]}, {r.d[0], r.d[1], r.d[2]}, kLength).has_value();
    });
    const Seconds bullet = time_run([&] {
      bullet_found = 0;
      for (const Ray& r : rays) {
        btCollisionWorld::ClosestRayResultCallback c(bullet_from(r), bullet_to(r, kLength));
        bw.world.rayTest(bullet_from(r), bullet_to(r, kLength), c);
        bullet_found += c.hasHit();
      }
    });
    // Every hit sorted, first taken: what a closest hit cost before.
    const Seconds all_hits = time_run([&] {
      for (const Ray& r : rays) benchmark::DoNotOptimize(w.bp.query_ray(r.o, r.d, kLength));
    });
    // Whole rays (max_t infinite: through the world): where the early out
    // skips most of what query_ray collects and sorts.
    closest_inf_runs.push_back(time_run([&] {
      for (const Ray& r : rays)
        benchmark::DoNotOptimize(w.bp.raycast_closest({r.o[0], r.o[1], r.o[2]}, {r.d[0], r.d[1], r.d[2]}, kInf));
    }));
    all_hits_inf_runs.push_back(time_run([&] {
      inf_hits = 0;
      for (const Ray& r : rays) inf_hits += w.bp.query_ray(r.o, r.d, kInf).size();
    }));
    ours_runs.push_back(ours);
    bullet_runs.push_back(bullet);
    all_hits_runs.push_back(all_hits);
    state.SetIterationTime(ours.wall);
  }
  // Checked against a scan (same slab test); Bullet's object compared.
  std::uint64_t same_as_bullet = 0, starts_inside = 0;
  for (int i = 0; i < kChecked; ++i) {
    const Ray& r = rays[static_cast<std::size_t>(i)];
    const hbp::detail::RaySegment seg(r.o, r.d, kLength);
    std::pair<float, Handle> best{std::numeric_limits<float>::infinity(), hbp::kInvalidHandle};
    for (std::uint32_t k = 0; k < n; ++k) {
      const Aabb b = w.boxes.get(k);
      float t;
      if (seg.hits(b.min, b.max, t)) best = std::min(best, std::pair<float, Handle>{t, k});
    }
    const std::optional<hbp::RayHit> got = w.bp.raycast_closest({r.o[0], r.o[1], r.o[2]}, {r.d[0], r.d[1], r.d[2]}, kLength);
    if (got.has_value() != (best.second != hbp::kInvalidHandle) || (got && (got->handle != best.second || got->t != best.first)))
      throw std::runtime_error("closest ray " + std::to_string(i) + " differs from brute force");
    btCollisionWorld::ClosestRayResultCallback c(bullet_from(r), bullet_to(r, kLength));
    bw.world.rayTest(bullet_from(r), bullet_to(r, kLength), c);
    same_as_bullet += c.hasHit() ? (got && static_cast<Handle>(c.m_collisionObject->getUserIndex()) == got->handle) : !got;
    starts_inside += got && got->t == 0;
  }
  state.counters["starts_inside_in_check"] = static_cast<double>(starts_inside) / kChecked;
  bullet_rate_counters(state, "rays", ours_runs, bullet_runs);
  state.counters["ours_all_hits_rays_per_cpu_s"] = kQueries / median_run(all_hits_runs).cpu;
  state.counters["ours_closest_whole_rays_per_cpu_s"] = kQueries / median_run(closest_inf_runs).cpu;
  state.counters["ours_all_hits_whole_rays_per_cpu_s"] = kQueries / median_run(all_hits_inf_runs).cpu;
  state.counters["hits_per_whole_ray"] = static_cast<double>(inf_hits) / kQueries;
  state.counters["rays_with_hit"] = static_cast<double>(found) / kQueries;
  state.counters["bullet_rays_with_hit"] = static_cast<double>(bullet_found) / kQueries;
  state.counters["same_object_as_bullet_in_check"] = static_cast<double>(same_as_bullet) / kChecked;
  state.SetItemsProcessed(state.iterations() * kQueries);
}

void BoxCasts(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  CastWorld& w = kept_world<CastWorld>(n);
  BulletQueryWorld& bw = w.bullet;
  // Boxes of the objects' sizes at random places, cast 20 m along the rays' directions.
  constexpr float kLength = 20;
  const std::vector<Ray> rays = random_rays(w.side, 5);
  hbp::Random rng(6);
  std::vector<Aabb> boxes(kQueries);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Aabb o = w.boxes.get(rng.below(n));
    for (int k = 0; k < 3; ++k) {
      const float half = 0.5f * (o.max[k] - o.min[k]);
      boxes[i].min[k] = rays[i].o[k] - half;
      boxes[i].max[k] = rays[i].o[k] + half;
    }
  }
  const auto displacement = [&](std::size_t i) {
    return hbp::BroadPhase::Vec3f{kLength * rays[i].d[0], kLength * rays[i].d[1], kLength * rays[i].d[2]};
  };
  std::vector<std::unique_ptr<btBoxShape>> shapes;
  for (const Aabb& b : boxes)
    shapes.push_back(std::make_unique<btBoxShape>(0.5f * btVector3(b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2])));
  const auto centre = [&](std::size_t i) {
    const Aabb& b = boxes[i];
    return btVector3(0.5f * (b.min[0] + b.max[0]), 0.5f * (b.min[1] + b.max[1]), 0.5f * (b.min[2] + b.max[2]));
  };
  std::uint64_t hits = 0, bullet_found = 0;
  std::vector<Seconds> ours_runs, bullet_runs;
  std::vector<Handle> out;
  w.bp.raycast_closest({0, 0, 0}, {1, 0, 0}, 1);  // builds the tree: not timed
  for (auto _ : state) {
    const Seconds ours = time_run([&] {
      hits = 0;
      for (std::size_t i = 0; i < boxes.size(); ++i) hits += w.bp.query_box_cast(boxes[i], displacement(i), out);
    });
    const Seconds bullet = time_run([&] {
      bullet_found = 0;
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        const btVector3 from = centre(i);
        const btVector3 to = from + kLength * btVector3(rays[i].d[0], rays[i].d[1], rays[i].d[2]);
        btCollisionWorld::ClosestConvexResultCallback c(from, to);
        bw.world.convexSweepTest(shapes[i].get(), btTransform(btQuaternion::getIdentity(), from),
                                 btTransform(btQuaternion::getIdentity(), to), c);
        bullet_found += c.hasHit();
      }
    });
    ours_runs.push_back(ours);
    bullet_runs.push_back(bullet);
    state.SetIterationTime(ours.wall);
  }
  // Checked against a scan (same rule); Bullet's closest object compared with our first hit.
  std::uint64_t same_as_bullet = 0, starts_inside = 0;
  for (int i = 0; i < kChecked; ++i) {
    const auto d = displacement(static_cast<std::size_t>(i));
    const hbp::detail::BoxCast cast(boxes[static_cast<std::size_t>(i)], d.data());
    const auto want = scan_hits(w.boxes, [&](const float* lo, const float* hi, float& t) { return cast.hits(lo, hi, t); });
    const std::vector<Handle> want_h = handles_of(want);
    if (w.bp.query_box_cast(boxes[static_cast<std::size_t>(i)], d) != want_h)
      throw std::runtime_error("box cast " + std::to_string(i) + " differs from brute force");
    const btVector3 from = centre(static_cast<std::size_t>(i));
    const btVector3 to = from + kLength * btVector3(rays[static_cast<std::size_t>(i)].d[0],
                                                    rays[static_cast<std::size_t>(i)].d[1],
                                                    rays[static_cast<std::size_t>(i)].d[2]);
    btCollisionWorld::ClosestConvexResultCallback c(from, to);
    bw.world.convexSweepTest(shapes[static_cast<std::size_t>(i)].get(), btTransform(btQuaternion::getIdentity(), from),
                             btTransform(btQuaternion::getIdentity(), to), c);
    same_as_bullet += c.hasHit() ? (!want_h.empty() && static_cast<Handle>(c.m_hitCollisionObject->getUserIndex()) == want_h[0])
                                 : want_h.empty();
    starts_inside += !want.empty() && want[0].first == 0;
  }
  state.counters["starts_overlapping_in_check"] = static_cast<double>(starts_inside) / kChecked;
  bullet_rate_counters(state, "casts", ours_runs, bullet_runs);
  state.counters["hits_per_cast"] = static_cast<double>(hits) / kQueries;
  state.counters["bullet_casts_with_hit"] = static_cast<double>(bullet_found) / kQueries;
  state.counters["same_first_object_as_bullet_in_check"] = static_cast<double>(same_as_bullet) / kChecked;
  state.SetItemsProcessed(state.iterations() * kQueries);
}

BENCHMARK(MostlyStatic)->Args({1000000, 10000, 2, 1})->Args({1000000, 10000, 1, 1})->Args({1000000, 10000, 2, 0})->Args({1000000, 10000, 1, 0})->UseManualTime()
    ->Unit(benchmark::kMillisecond)->Iterations(30);
// 20 frames: the ratio of medians moves by a few percent between runs of 10.
BENCHMARK(AllMoving)->Args({128000, 2})->Args({1024000, 2})->Args({1024000, 1})->UseManualTime()->Unit(benchmark::kMillisecond)
    ->Iterations(20);
BENCHMARK(DoublePrecision)->Args({1000000, 2, 1})->Args({1000000, 2, 0})->Args({1000000, 1, 1})->Args({1000000, 1, 0})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)->Iterations(15);
// 100 frames: a frame is under a millisecond, so the medians need many.
BENCHMARK(SleepingWorld)->Args({1000000, 2})->Args({1000000, 1})->UseManualTime()->Unit(benchmark::kMillisecond)
    ->Iterations(100);
BENCHMARK(Snapshot)->Args({1000000, 1})->Args({1000000, 100})->UseManualTime()->Unit(benchmark::kMillisecond)
    ->Iterations(20);
BENCHMARK(BoxQueries)->Arg(1000000)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(RayQueries)->Arg(1000000)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(ClosestRays)->Arg(1000000)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BoxCasts)->Arg(1000000)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
