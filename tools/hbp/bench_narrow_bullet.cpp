// SPDX-License-Identifier: MIT
// hbp bench narrow: the narrow phase's throughput and verdicts against
// Bullet's btCollisionDispatcher (default configuration, margins 0, each
// pair's algorithm and manifold kept from frame to frame) on the same
// candidate pairs: the paper scene's broad-phase pairs, frame after frame.
// One thread, CPU time of the thread for both sides, in the same run.
//
// Per frame it also checks (untimed) that every contact we report is
// certified by the intersection-only test, and classifies each verdict that
// differs from Bullet's by the pair's signed distance (agreement band of
// docs/narrow-phase.md: |distance| <= 1e-4 m + 2e-6 x (sum of bounding radii)).
#include "bench_narrow_bullet.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "memory_probe.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/narrow/libccd_solver.hpp"
#include "hbp/narrow/narrow_cache.hpp"
#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/benchdata/random_pairs.hpp"
#include "hbp/scenario.hpp"
#include "support/clock.hpp"
#include "support/percentile.hpp"

#ifdef HBP_HAVE_BASELINES
#include "hbp/baselines/bullet_narrow_phase.hpp"
#include "hbp/baselines/bullet_shape_pair_test.hpp"
#endif

namespace hbp::cli {
namespace {

struct NarrowBenchArgs {
  std::uint32_t n = 100000;
  std::uint32_t frames = 10;
  std::uint32_t runs = 3;
  std::uint64_t seed = 0;
  std::uint64_t random_pairs = 0;
  bool no_bullet = false;
  double depth_tolerance = narrow::kContactDepthTolerance;
};

double band(const Shape& a, const Shape& b) {
  const double ra = 0.5 * std::sqrt(a.size.x * a.size.x + a.size.y * a.size.y + a.size.z * a.size.z);
  const double rb = 0.5 * std::sqrt(b.size.x * b.size.x + b.size.y * b.size.y + b.size.z * b.size.z);
  return 1e-4 + 2e-6 * (ra + rb);
}

constexpr double kShallow = 0.01;  // m

struct Checks {
  std::uint64_t false_contacts = 0;  // reported contact, intersection-only test says apart
  std::uint64_t disagree_band = 0, disagree_out = 0;
  // We report a contact shallower than kShallow that Bullet's dispatcher
  // does not (its float GJK declares shallow overlaps apart).
  std::uint64_t bullet_missed_shallow = 0;
  // Bullet's dispatcher differs from us, Bullet's own GJK/EPA
  // (btGjkEpaSolver2) on the same pair agrees with us.
  std::uint64_t dispatcher_only = 0;
  // Both Bullet paths differ from us; libccd's MPR and GJK agree with us.
  std::uint64_t ccd_agrees = 0;
};

// Verdicts of the frame: ours (contacts, in pair order) against the
// intersection-only test and against Bullet's.
void check_frame(const std::vector<Shape>& shapes, const std::vector<Pair>& pairs,
                 const std::vector<Contact>& contacts, const std::vector<std::uint8_t>* bullet, Checks& c,
                 std::uint32_t frame) {
  std::vector<std::uint8_t> ours(pairs.size(), 0);
  std::size_t j = 0;
  for (std::size_t k = 0; k < pairs.size() && j < contacts.size(); ++k) {
    if (contacts[j].a == pairs[k].a && contacts[j].b == pairs[k].b) {
      ours[k] = 1;
      ++j;
    }
  }
  if (j != contacts.size()) throw Error("bench narrow: contacts are not in pair order");
  const NarrowPhase boolean_only(NarrowOptions{.contacts = false});
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Shape& a = shapes[pairs[k].a];
    const Shape& b = shapes[pairs[k].b];
    if (ours[k] && !intersect(a, b, nullptr)) {
      if (c.false_contacts < 5)
        std::fprintf(stderr, "  frame %u: FALSE CONTACT %u-%u (intersection-only: apart, distance %.3g m)\n", frame,
                     pairs[k].a, pairs[k].b, signed_distance(a, b));
      ++c.false_contacts;
    }
    if (bullet && (*bullet)[k] != ours[k]) {
      const double d = signed_distance(a, b);
      if (std::fabs(d) <= band(a, b)) {
        ++c.disagree_band;
      } else if (ours[k] && d > -kShallow) {
        ++c.bullet_missed_shallow;
#ifdef HBP_HAVE_BASELINES
      } else if (baselines::bullet_shape_pair_test(a, b).intersecting == static_cast<bool>(ours[k])) {
        // Bullet's own GJK/EPA on the pair agrees with us: the dispatcher's
        // verdict comes from its persistent manifold (points kept from
        // earlier frames, the box-box detector's clipped points).
        ++c.dispatcher_only;
#endif
      } else if (narrow::libccd_available() &&
                 intersect(a, b, nullptr, NarrowMethod::LibccdMpr) == static_cast<bool>(ours[k]) &&
                 intersect(a, b, nullptr, NarrowMethod::LibccdGjkEpa) == static_cast<bool>(ours[k])) {
        // Bullet is the odd one out of three implementations (libccd's MPR
        // and GJK agree with us).
        ++c.ccd_agrees;
      } else {
        if (c.disagree_out < 5)
          std::fprintf(stderr, "  frame %u: pair %u-%u (%s-%s): ours %d, Bullet %d, signed distance %.4g m\n", frame,
                       pairs[k].a, pairs[k].b, shape_kind_name(a.kind), shape_kind_name(b.kind), ours[k],
                       (*bullet)[k], d);
        ++c.disagree_out;
      }
    }
  }
}

struct RunTimes {
  double ours_first = 0, bullet_first = 0;    // CPU ms, frame 0 (cold cache / new manifolds)
  double ours_steady = 0, bullet_steady = 0;  // CPU ms, frames 1.., summed
  std::uint64_t pairs_first = 0, pairs_steady = 0;
};

void run_bench_narrow(const NarrowBenchArgs& a) {
  if (a.frames < 2) throw InvalidInput("--frames must be at least 2 (the first frame is the cold one)");
  if (a.runs == 0) throw InvalidInput("--runs must be at least 1");
#ifndef HBP_HAVE_BASELINES
  const bool with_bullet = false;
#else
  const bool with_bullet = !a.no_bullet;
#endif
  // Checked before anything runs (InvalidInput names the value).
  const NarrowPhase narrow(NarrowOptions{.depth_tolerance = a.depth_tolerance});
  std::printf("hbp bench narrow: paper scene, n = %u, seed %llu, %u frames x %u runs, one thread, CPU time\n", a.n,
              static_cast<unsigned long long>(a.seed), a.frames, a.runs);
  std::printf("ours: NarrowPhase (contacts, %s, depth tolerance %g relative) with its per-pair cache; Bullet: %s\n",
              narrow_method_name(NarrowMethod::Auto), a.depth_tolerance,
              with_bullet ? "btCollisionDispatcher, default configuration, margins 0, persistent manifolds"
                          : "not measured");
  // The host's cache state around the run (memory_probe.hpp): ratios taken
  // in different states compare; absolute times only in the same one.
  std::printf("memory latency at start: %s\n", memory_latency_text(probe_memory_latency()).c_str());
  std::vector<RunTimes> runs;
  Checks checks;
  std::uint64_t contacts_total = 0;
  for (std::uint32_t r = 0; r < a.runs; ++r) {
    ScenarioParams sp;
    sp.n = a.n;
    sp.seed = a.seed;
    sp.frames = a.frames;
    Scenario scene(sp);
    HybridBroadPhase bp(BroadPhaseOptions{.engine = "sw", .threads = 1, .sorted = true});
    NarrowCache cache;
    std::vector<NarrowCacheEntry> learned;
#ifdef HBP_HAVE_BASELINES
    std::unique_ptr<baselines::BulletNarrowPhase> bullet;
    if (with_bullet) bullet = std::make_unique<baselines::BulletNarrowPhase>(scene.shapes());
#endif
    BoxArray boxes;
    std::vector<Contact> contacts;
    std::vector<std::uint8_t> bullet_verdicts;
    RunTimes t;
    for (std::uint32_t f = 0; f < a.frames; ++f) {
      if (f > 0) scene.step();
      scene.compute_boxes(boxes);
      const std::vector<Pair>& pairs = bp.update(boxes);
      contacts.clear();
      const double t0 = thread_cpu_ms();
      learned.clear();
      narrow.process(scene.shapes(), pairs.data(), pairs.size(), contacts, &cache, &learned);
      cache.commit(&learned, 1, scene.size());
      const double ours_ms = thread_cpu_ms() - t0;
      double bullet_ms = 0;
#ifdef HBP_HAVE_BASELINES
      if (bullet) {
        bullet->prepare(scene.shapes(), pairs);
        const double t1 = thread_cpu_ms();
        bullet->run(bullet_verdicts);
        bullet_ms = thread_cpu_ms() - t1;
      }
#endif
      if (f == 0) {
        t.ours_first = ours_ms;
        t.bullet_first = bullet_ms;
        t.pairs_first = pairs.size();
      } else {
        t.ours_steady += ours_ms;
        t.bullet_steady += bullet_ms;
        t.pairs_steady += pairs.size();
      }
      if (r == 0) {
        contacts_total += contacts.size();
        check_frame(scene.shapes(), pairs, contacts, with_bullet ? &bullet_verdicts : nullptr, checks, f);
        std::printf("  frame %2u: %zu candidate pairs, %zu contacts; ours %.2f ms", f, pairs.size(),
                    contacts.size(), ours_ms);
        if (with_bullet) std::printf(", Bullet %.2f ms (x%.2f)", bullet_ms, bullet_ms / ours_ms);
        std::printf("\n");
      }
    }
    runs.push_back(t);
  }
  auto col = [&](auto get) {
    std::vector<double> v;
    for (const auto& t : runs) v.push_back(get(t));
    return median(v);
  };
  const double of = col([](const RunTimes& t) { return t.ours_first; });
  const double bf = col([](const RunTimes& t) { return t.bullet_first; });
  const double os = col([](const RunTimes& t) { return t.ours_steady; });
  const double bs = col([](const RunTimes& t) { return t.bullet_steady; });
  const double pf = static_cast<double>(runs[0].pairs_first), ps = static_cast<double>(runs[0].pairs_steady);
  std::printf("\n| frames | pairs | ours ms (CPU) | ours pairs/s | Bullet ms (CPU) | Bullet pairs/s | ours / Bullet |\n");
  std::printf("| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  std::printf("| first (cold cache) | %.0f | %.2f | %.0f k | %.2f | %.0f k | %.2fx |\n", pf, of, pf / of,
              bf, with_bullet ? pf / bf : 0.0, with_bullet ? bf / of : 0.0);
  std::printf("| steady (frames 1-%u) | %.0f | %.2f | %.0f k | %.2f | %.0f k | %.2fx |\n", a.frames - 1, ps, os,
              ps / os, bs, with_bullet ? ps / bs : 0.0, with_bullet ? bs / os : 0.0);
  std::printf("(medians of %u runs; pairs/s per core = pairs / thread CPU time)\n", a.runs);
  std::printf("memory latency at end: %s\n", memory_latency_text(probe_memory_latency()).c_str());
  std::printf("verdicts (run 1, every frame): %llu contacts; %llu reported contacts the intersection-only test "
              "calls apart (must be 0)",
              static_cast<unsigned long long>(contacts_total), static_cast<unsigned long long>(checks.false_contacts));
  if (with_bullet)
    std::printf("; differ from Bullet's dispatcher: %llu within the band, %llu shallow contacts (< %g m) Bullet "
                "misses, %llu where Bullet's own GJK/EPA on the pair agrees with us, %llu where libccd's MPR and "
                "GJK agree with us, %llu other",
                static_cast<unsigned long long>(checks.disagree_band),
                static_cast<unsigned long long>(checks.bullet_missed_shallow), kShallow,
                static_cast<unsigned long long>(checks.dispatcher_only),
                static_cast<unsigned long long>(checks.ccd_agrees),
                static_cast<unsigned long long>(checks.disagree_out));
  std::printf("\n");

  std::uint64_t random_false = 0, random_hits = 0;
  if (a.random_pairs > 0) {
    ShapePairGenerator gen(a.seed);
    std::vector<Shape> two(2);
    const Pair first_second{0, 1};
    std::vector<Contact> contact;
    for (std::uint64_t k = 0; k < a.random_pairs; ++k) {
      const ShapePair p = gen.next();
      two[0] = p.a;
      two[1] = p.b;
      contact.clear();
      const bool hit = narrow.process(two, &first_second, 1, contact) == 1;  // at the run's tolerance
      random_hits += hit;
      if (hit && !intersect(p.a, p.b, nullptr)) {
        if (random_false < 5)
          std::fprintf(stderr, "  random pair %llu: FALSE CONTACT (distance %.3g m)\n",
                       static_cast<unsigned long long>(k), signed_distance(p.a, p.b));
        ++random_false;
      }
    }
    std::printf("random pairs: %llu (ShapePairGenerator seed %llu), %llu contacts, %llu the intersection-only test "
                "calls apart (must be 0)\n",
                static_cast<unsigned long long>(a.random_pairs), static_cast<unsigned long long>(a.seed),
                static_cast<unsigned long long>(random_hits), static_cast<unsigned long long>(random_false));
  }
  if (checks.false_contacts || random_false || checks.disagree_out)
    throw Error("bench narrow: " + std::to_string(checks.false_contacts + random_false) + " false contact(s), " +
                std::to_string(checks.disagree_out) + " verdict(s) outside the agreement band with Bullet");
}

}  // namespace

void add_bench_narrow(CLI::App* bench) {
  auto a = std::make_shared<NarrowBenchArgs>();
  CLI::App* cmd = bench->add_subcommand(
      "narrow", "Narrow phase vs Bullet's dispatcher on the paper scene's candidate pairs (one thread, CPU time)");
  cmd->add_option("--n", a->n, "Objects")->capture_default_str();
  cmd->add_option("--frames", a->frames, "Consecutive frames per run (the first is the cold one)")
      ->capture_default_str();
  cmd->add_option("--runs", a->runs, "Runs (medians are reported)")->capture_default_str();
  cmd->add_option("--seed", a->seed, "Scene seed")->capture_default_str();
  cmd->add_option("--random-pairs", a->random_pairs,
                  "Also check this many random pairs (near-touching half) for false contacts")
      ->capture_default_str();
  cmd->add_flag("--no-bullet", a->no_bullet, "Ours only");
  cmd->add_option("--depth-tolerance", a->depth_tolerance,
                  "Relative tolerance of our contact depths (NarrowOptions::depth_tolerance)")
      ->capture_default_str();
  cmd->callback([a] { run_bench_narrow(*a); });
}

}  // namespace hbp::cli
