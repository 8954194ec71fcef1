// SPDX-License-Identifier: MIT
// Resource limits and input validation at the library boundary.
//
// Pair explosions run in a child process (this binary re-executed with
// HBP_LIMITS_CHILD set), which reports its own peak resident memory, so an
// unbounded explosion cannot take the test runner down with it. Outside sanitizer builds the child also caps its address
// space (RLIMIT_AS), turning a missing limit into std::bad_alloc instead of
// a machine-wide out-of-memory.
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include "hbp/broad_phase.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/cell_engine.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/limits.hpp"
#include "sanitizers.hpp"

extern char** environ;

namespace {

constexpr bool kSanitized = hbp::test::kAddressSanitizer || hbp::test::kThreadSanitizer;

using hbp::Aabb;
using hbp::BoxArray;
using hbp::HybridBroadPhase;
using hbp::Pair;

constexpr std::size_t kMiB = 1024 * 1024;

BoxArray coincident(std::size_t n) {
  BoxArray b(n);
  for (std::size_t i = 0; i < n; ++i) b.set(i, {{0, 0, 0}, {1, 1, 1}});
  return b;
}

// n unit cubes on a grid of spacing 2: no pairs at all.
BoxArray spread(std::size_t n) {
  const auto side = static_cast<std::size_t>(std::ceil(std::cbrt(static_cast<double>(n))));
  BoxArray b(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float x = 2.0f * float(i % side), y = 2.0f * float(i / side % side), z = 2.0f * float(i / side / side);
    b.set(i, {{x, y, z}, {x + 1, y + 1, z + 1}});
  }
  return b;
}

// ---- Child side ---------------------------------------------------------------
// HBP_LIMITS_CHILD="<job> <engine> <n> <max_pairs> [<address space MiB>]",
// job: coincident | spread; the address-space cap defaults to 2048 MiB.
// Prints its peak resident memory and its peak address space (VmHWM and
// VmPeak of the fresh address space: wait4's ru_maxrss would include the
// parent's, inherited through exec) on one line, then one of "pairs
// <count>", "capacity <message>", "bad_alloc" or "error <message>", and
// exits without running any test.

// A "VmXxx: <kB> kB" line of /proc/self/status, in bytes.
std::size_t status_bytes(const char* field) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (f == nullptr) return 0;
  char line[256];
  std::size_t kib = 0;
  const std::string format = std::string(field) + ": %zu kB";
  while (std::fgets(line, sizeof line, f) != nullptr)
    if (std::sscanf(line, format.c_str(), &kib) == 1) break;
  std::fclose(f);
  return kib * 1024;
}

int child_main(const char* spec) {
  std::istringstream in(spec);
  std::string job, engine;
  std::size_t n = 0;
  std::uint64_t max_pairs = 0;
  std::size_t cap_mib = 2048;
  in >> job >> engine >> n >> max_pairs;
  if (!(in >> cap_mib)) cap_mib = 2048;
  if (!kSanitized) {
    const rlimit cap{cap_mib * kMiB, cap_mib * kMiB};
    setrlimit(RLIMIT_AS, &cap);
  }
  // Runs before main(): register the hardware models' engines as main does.
  hbp::hw::register_cell_engines();
  std::string result;
  try {
    const BoxArray boxes = job == "coincident" ? coincident(n) : spread(n);
    HybridBroadPhase bp({.engine = engine, .threads = 2, .max_pairs = max_pairs});
    result = "pairs " + std::to_string(bp.update(boxes).size());
  } catch (const hbp::CapacityExceeded& e) {
    result = std::string("capacity ") + e.what();
  } catch (const std::bad_alloc&) {
    result = "bad_alloc";
  } catch (const std::exception& e) {
    result = std::string("error ") + e.what();
  }
  std::printf("%zu %zu\n%s\n", status_bytes("VmHWM"), status_bytes("VmPeak"), result.c_str());
  std::fflush(stdout);
  std::_Exit(0);
}

const bool kChildHook = [] {
  if (const char* spec = std::getenv("HBP_LIMITS_CHILD")) child_main(spec);
  return true;
}();

// ---- Parent side --------------------------------------------------------------

struct ChildResult {
  std::string output;        // the child's line
  std::size_t peak_rss = 0;  // bytes (the child's VmHWM)
  std::size_t peak_address_space = 0;  // bytes (the child's VmPeak)
  int status = 0;
};

ChildResult run_child(const std::string& spec) {
  std::vector<std::string> env_store;
  for (char** e = environ; *e != nullptr; ++e)
    if (std::strncmp(*e, "HBP_LIMITS_CHILD=", 17) != 0) env_store.emplace_back(*e);
  env_store.push_back("HBP_LIMITS_CHILD=" + spec);
  std::vector<char*> envp;
  for (std::string& s : env_store) envp.push_back(s.data());
  envp.push_back(nullptr);
  char name[] = "test_limits_child";
  char* argv[] = {name, nullptr};

  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv, envp.data());
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (rc != 0) {
    close(fds[0]);
    throw std::runtime_error("posix_spawn failed");
  }
  ChildResult r;
  char buf[4096];
  for (ssize_t got; (got = read(fds[0], buf, sizeof buf)) > 0;) r.output.append(buf, static_cast<std::size_t>(got));
  close(fds[0]);
  waitpid(pid, &r.status, 0);
  while (!r.output.empty() && r.output.back() == '\n') r.output.pop_back();
  const std::size_t eol = r.output.find('\n');
  if (eol != std::string::npos) {
    char* end = nullptr;
    r.peak_rss = std::strtoull(r.output.c_str(), &end, 10);
    r.peak_address_space = std::strtoull(end, nullptr, 10);
    r.output.erase(0, eol + 1);
  }
  return r;
}

std::string describe(const ChildResult& r) {
  return "child said \"" + r.output + "\", peak RSS " + std::to_string(r.peak_rss / kMiB) + " MiB, peak address space " +
         std::to_string(r.peak_address_space / kMiB) + " MiB, status " + std::to_string(r.status);
}

// ---- Pair explosion -----------------------------------------------------------

// Every built-in engine ("sw", "sw-allpairs", "brute", "ae", "mo", "ae-sim",
// "mo-sim"; the Verilated ones are tested in rtl/tb).
std::vector<std::string> builtin_engines() {
  std::vector<std::string> names;
  for (const std::string& name : hbp::cell_engine_names())
    if (name.rfind("rtl-", 0) != 0 && name.rfind("limits-", 0) != 0) names.push_back(name);
  return names;
}

// n coincident boxes (n(n-1)/2 pairs) with max_pairs = 10^6: the frame must
// stop with CapacityExceeded while the process stays small. Stopping near
// the limit costs ~8 bytes per pair in the engine's output plus the same in
// the cell's list: ~16 MiB over the process's baseline.
constexpr std::size_t kExplosionBound = kSanitized ? 1536 * kMiB : 64 * kMiB;

void expect_explosion_stopped(const std::string& engine, std::size_t n) {
  const ChildResult r = run_child("coincident " + engine + " " + std::to_string(n) + " 1000000");
  std::printf("explosion %zu coincident, engine %s, max_pairs 1e6: %s\n", n, engine.c_str(), describe(r).c_str());
  EXPECT_TRUE(WIFEXITED(r.status)) << engine << ": " << describe(r);
  EXPECT_EQ(r.output.rfind("capacity ", 0), 0u) << engine << ": " << describe(r);
  EXPECT_NE(r.output.find("max_pairs"), std::string::npos) << engine << ": " << describe(r);
  EXPECT_LT(r.peak_rss, kExplosionBound) << engine << ": the explosion was not stopped near max_pairs: " << describe(r);
}

// 16,000 coincident boxes (127,992,000 pairs) fit one call of every engine
// but the area-efficient ones (tiled in calls of 1024): before the engines
// honoured the pair limit, brute and mo-sim stored all 1.3e8 pairs (1.9 GiB
// and 1.0 GiB) before the pipeline counted them.
TEST(Limits, PairExplosionStopsWithinMaxPairsEveryEngine) {
  for (const std::string& engine : builtin_engines()) expect_explosion_stopped(engine, 16000);
}

// 20,000 boxes: tiled for the many-object buffer (16,384) too.
TEST(Limits, PairExplosionStopsWithinMaxPairsTiled) {
  for (const char* engine : {"sw", "ae", "mo"}) expect_explosion_stopped(engine, 20000);
}

// The per-call limit itself, engine by engine, counted at the throw: one
// find_pairs / find_owned_pairs call on coincident boxes appends more than
// the limit (else it could not know) but at most one kernel round beyond it
// (2(n + 16) pairs: the software engine's smallest output round; a row for
// brute and the hardware-order loops, one cycle's lines for the models).
// Pairs already in `out` do not count. With the limit equal to the cell's
// pair count the call completes.
TEST(Limits, EveryEngineStopsAtItsPairLimit) {
  const std::vector<Pair> sentinel(5, Pair{7, 9});
  for (const std::string& name : builtin_engines()) {
    auto engine = hbp::make_cell_engine(name);
    const auto n = static_cast<std::uint32_t>(std::min<std::uint64_t>(engine->capacity(), 3000));
    const BoxArray boxes = coincident(n);
    const std::uint64_t limit = 100000;
    engine->set_pair_limit(limit);
    for (const bool owned : {false, true}) {
      std::vector<Pair> out = sentinel;
      try {
        if (owned)
          engine->find_owned_pairs(boxes, hbp::CellRegion::everything(), out);
        else
          engine->find_pairs(boxes, out);
        ADD_FAILURE() << name << ": " << n << " coincident boxes passed a pair limit of " << limit;
      } catch (const hbp::CapacityExceeded& e) {
        EXPECT_NE(std::string(e.what()).find("max_pairs"), std::string::npos) << name << ": " << e.what();
      }
      const std::uint64_t appended = out.size() - sentinel.size();
      std::printf("engine %-12s %s: n %u, limit %llu, stored %llu at the throw\n", name.c_str(),
                  owned ? "find_owned_pairs" : "find_pairs      ", n, static_cast<unsigned long long>(limit),
                  static_cast<unsigned long long>(appended));
      EXPECT_GT(appended, limit) << name;
      EXPECT_LE(appended, limit + 2 * (std::uint64_t{n} + 16)) << name;
      EXPECT_TRUE(std::equal(sentinel.begin(), sentinel.end(), out.begin())) << name;
    }
    // Exactly at the limit: complete; one fewer: stop.
    const BoxArray few = coincident(600);
    const std::uint64_t total = 600 * 599 / 2;
    engine->set_pair_limit(total);
    std::vector<Pair> out;
    engine->find_pairs(few, out);
    EXPECT_EQ(out.size(), total) << name;
    engine->set_pair_limit(total - 1);
    out.clear();
    EXPECT_THROW(engine->find_pairs(few, out), hbp::CapacityExceeded) << name;
  }
}

std::vector<std::string> limit_engines() {
  static const bool registered = [] {
    hbp::register_cell_engine("limits-ae-small", [] {
      hbp::hw::ModelConfig cfg;
      cfg.m = 4;
      cfg.depth = 64;
      return hbp::hw::make_area_efficient_engine(cfg);
    });
    return true;
  }();
  (void)registered;
  return {"sw", "sw-allpairs", "ae", "mo", "limits-ae-small"};
}

// A frame with exactly max_pairs pairs completes (the limit is on the
// frame's de-duplicated pairs, not on work done in tiles), one pair fewer
// stops, and the same instance then runs the next frame normally.
TEST(Limits, MaxPairsIsExactAndTheInstanceSurvives) {
  const std::size_t n = 3000;
  const std::uint64_t total = n * (n - 1) / 2;  // 4,498,500
  const BoxArray boom = coincident(n);
  const BoxArray calm = spread(4096);
  for (const std::string& engine : limit_engines()) {
    HybridBroadPhase exact({.engine = engine, .threads = 2, .max_pairs = total});
    const auto& got = exact.update(boom);
    ASSERT_EQ(got.size(), total) << engine;
    EXPECT_EQ(got.front(), (Pair{0, 1})) << engine;
    EXPECT_EQ(got.back(), (Pair{n - 2, n - 1})) << engine;
    EXPECT_EQ(exact.stats().pairs, total);

    HybridBroadPhase below({.engine = engine, .threads = 2, .max_pairs = total - 1});
    EXPECT_THROW(below.update(boom), hbp::CapacityExceeded) << engine;
    EXPECT_TRUE(below.update(calm).empty()) << engine;
    EXPECT_THROW(below.update(boom), hbp::CapacityExceeded) << engine;
    BoxArray few = calm;
    few.set(1, {{0, 0, 0}, {1, 1, 1}});  // one pair with box 0
    EXPECT_EQ(below.update(few), (std::vector<Pair>{{0, 1}})) << engine;
  }
}

TEST(Limits, MaxPairsThroughTheNarrowPhaseSink) {
  const BoxArray boom = coincident(2500);
  HybridBroadPhase bp({.engine = "sw", .cell_limit = 64, .threads = 2, .max_pairs = 100000});
  std::size_t delivered = 0;
  EXPECT_THROW(bp.update(boom, [&](std::uint32_t, const Pair*, std::size_t count) { delivered += count; }),
               hbp::CapacityExceeded);
  EXPECT_LE(delivered, 100000u);
  const BoxArray calm = spread(1000);
  delivered = 0;
  EXPECT_TRUE(bp.update(calm, [&](std::uint32_t, const Pair*, std::size_t count) { delivered += count; }).empty());
  EXPECT_EQ(delivered, 0u);
}

// A large but legitimate explosion without a limit is exact.
TEST(Limits, UnlimitedExplosionIsExact) {
  const std::size_t n = 4000;
  const BoxArray boom = coincident(n);
  HybridBroadPhase bp({.engine = "sw", .threads = 2});
  const auto& got = bp.update(boom);
  ASSERT_EQ(got.size(), n * (n - 1) / 2);
  EXPECT_EQ(got, hbp::brute_force_pairs(boom));
}

// Peak resident memory per object (no pairs) and per pair, from child
// processes; the figures of docs/robustness.md.
TEST(Limits, MemoryPerObjectAndPerPair) {
  const ChildResult small = run_child("spread sw 1000 0");
  const ChildResult large = run_child("spread sw 512000 0");
  const ChildResult calm = run_child("spread sw 6000 0");
  const ChildResult boom = run_child("coincident sw 6000 0");
  ASSERT_EQ(small.output, "pairs 0") << describe(small);
  ASSERT_EQ(large.output, "pairs 0") << describe(large);
  ASSERT_EQ(boom.output, "pairs 17997000") << describe(boom);
  const double per_object =
      (static_cast<double>(large.peak_rss) - static_cast<double>(small.peak_rss)) / (512000.0 - 1000.0);
  const double per_pair = (static_cast<double>(boom.peak_rss) - static_cast<double>(calm.peak_rss)) / 17997000.0;
  std::printf("peak RSS: 1000 objects %zu MiB, 512000 objects %zu MiB -> %.0f bytes/object\n", small.peak_rss / kMiB,
              large.peak_rss / kMiB, per_object);
  std::printf("peak RSS: 6000 spread %zu MiB, 6000 coincident (17,997,000 pairs) %zu MiB -> %.1f bytes/pair\n",
              calm.peak_rss / kMiB, boom.peak_rss / kMiB, per_pair);
  EXPECT_GT(per_object, 24.0);  // at least the input boxes themselves
  EXPECT_GT(per_pair, 8.0);     // at least the output pairs themselves
  if (!kSanitized) {
    EXPECT_LT(per_object, 1024.0);
    EXPECT_LT(per_pair, 64.0);
  }
}

// Address space reserved ahead of use counts against a process's address
// space limit (ulimit -v, container limits) although it costs no memory:
// at the object limit, coincident boxes with max_pairs = 1000 must stop
// with CapacityExceeded under an 8 GiB cap (they used to map ~2.4 times
// their ~3.5 GB resident peak and fail with std::bad_alloc), and the peak
// address space stays near the peak resident memory.
TEST(Limits, AddressSpaceFollowsResidentMemoryAtTheObjectLimit) {
  if (kSanitized) GTEST_SKIP() << "the sanitizers' shadow memory is address space";
  const ChildResult r = run_child("coincident sw 16777215 1000 8192");
  std::printf("object limit, coincident, max_pairs 1000, 8 GiB address space: %s\n", describe(r).c_str());
  ASSERT_TRUE(WIFEXITED(r.status)) << describe(r);
  EXPECT_EQ(r.output.rfind("capacity ", 0), 0u) << describe(r);
  EXPECT_LT(static_cast<double>(r.peak_address_space), 1.5 * static_cast<double>(r.peak_rss)) << describe(r);
}

// One thread limit, checked when a broad phase is built: at it, a broad
// phase works (oneTBB runs no more workers than the machine has); past it,
// InvalidInput naming the option (above 65,536 a BroadPhase used to crash
// when destroyed).
TEST(Limits, ThreadCountAtAndPastTheLimit) {
  BoxArray boxes = coincident(3);
  {
    HybridBroadPhase h({.threads = hbp::kMaxThreads});
    EXPECT_EQ(h.update(boxes).size(), 3u);
    hbp::BroadPhase b({.threads = hbp::kMaxThreads});
    const hbp::Aabb box{{0, 0, 0}, {1, 1, 1}};
    const hbp::Aabb two[2] = {box, box};
    b.add(two);
    EXPECT_EQ(b.update().pairs.size(), 1u);
  }
  for (const unsigned threads : {hbp::kMaxThreads + 1, 65536u, 65537u, 70000u, 0x80000000u, 0xFFFFFFFFu}) {
    SCOPED_TRACE(threads);
    for (int which = 0; which < 2; ++which) {
      try {
        if (which == 0)
          HybridBroadPhase({.threads = threads});
        else
          hbp::BroadPhase({.threads = threads});
        ADD_FAILURE() << "accepted " << threads << " threads";
      } catch (const hbp::InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("threads: " + std::to_string(threads)), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(std::to_string(hbp::kMaxThreads)), std::string::npos) << e.what();
      }
    }
  }
}

// ---- Input validation ---------------------------------------------------------

struct Defect {
  const char* what;      // expected in the message
  char axis;             // expected in the message
  Aabb box;
};

std::vector<Defect> defects() {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  return {
      {"NaN", 'x', {{nan, 0, 0}, {1, 1, 1}}},
      {"NaN", 'z', {{0, 0, 0}, {1, 1, nan}}},
      {"NaN", 'y', {{0, -nan, 0}, {1, 1, 1}}},
      {"infinite", 'y', {{0, 0, 0}, {1, inf, 1}}},
      {"infinite", 'z', {{0, 0, -inf}, {1, 1, 1}}},
      {"infinite", 'x', {{-inf, 0, 0}, {inf, 1, 1}}},
      {"min > max", 'y', {{0, 2, 0}, {1, 1, 1}}},
      {"min > max", 'x', {{0.0f, 0, 0}, {-std::numeric_limits<float>::denorm_min(), 1, 1}}},
  };
}

TEST(Validation, RejectsNaNInfAndInvertedBoxesNamingTheFirstObject) {
  BoxArray good = spread(1000);
  for (const char* engine : {"sw", "sw-allpairs", "ae", "mo"}) {
    HybridBroadPhase bp({.engine = engine, .threads = 2});
    for (const Defect& d : defects()) {
      BoxArray bad = good;
      bad.set(777, d.box);
      bad.set(900, defects()[0].box);  // a later bad object is not the one named
      try {
        bp.update(bad);
        ADD_FAILURE() << engine << ": accepted a box with " << d.what;
      } catch (const hbp::InvalidInput& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("object 777:"), std::string::npos) << msg;
        EXPECT_NE(msg.find(d.what), std::string::npos) << msg;
        EXPECT_NE(msg.find(std::string("axis ") + d.axis), std::string::npos) << msg;
      }
      // The rejected frame leaves the instance usable.
      EXPECT_TRUE(bp.update(good).empty()) << engine;
    }
    BoxArray first = good;
    first.set(0, defects()[3].box);
    EXPECT_THROW(bp.update(first), hbp::InvalidInput);
    BoxArray last = good;
    last.set(999, defects()[6].box);
    try {
      bp.update(last);
      ADD_FAILURE() << "last box accepted";
    } catch (const hbp::InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("object 999:"), std::string::npos) << e.what();
    }
  }
}

TEST(Validation, AcceptsExtremeButValidBoxes) {
  const float big = std::numeric_limits<float>::max();
  const float tiny = std::numeric_limits<float>::denorm_min();
  BoxArray boxes;
  boxes.push_back({{-big, -big, -big}, {big, big, big}});
  boxes.push_back({{big, big, big}, {big, big, big}});
  boxes.push_back({{-0.0f, -0.0f, -0.0f}, {0.0f, 0.0f, 0.0f}});
  boxes.push_back({{tiny, tiny, tiny}, {tiny, tiny, tiny}});
  boxes.push_back({{-tiny, 0, 0}, {-0.0f, 0, 0}});
  for (const char* engine : {"sw", "sw-allpairs", "ae", "mo"}) {
    HybridBroadPhase bp({.engine = engine, .cell_limit = 2});
    const auto& got = bp.update(boxes);
    EXPECT_EQ(got, hbp::brute_force_pairs(boxes)) << engine;
    // Box 0 spans everything; 2 and 4 share x = 0 and the origin on y, z;
    // 2 and 3 do not meet (3 is above +0 on every axis).
    const std::vector<Pair> want = {{0, 1}, {0, 2}, {0, 3}, {0, 4}, {2, 4}};
    EXPECT_EQ(got, want) << engine;
  }
}

}  // namespace
