// SPDX-License-Identifier: MIT
// The engine's job system (hbp/task_system.hpp): BroadPhase and
// HybridBroadPhase give the same pairs, events and order under every task
// system — the default oneTBB arena on 1 and 2 threads, the library's
// serial and oneTBB task systems, and test systems that run a batch's tasks
// on their own threads in a scrambled order, or serially in reverse while
// claiming four threads (so the parallel code paths run) — and match a
// sweep-and-prune reference written here. The test systems also check the
// contract the library promises an engine: run() is called on the thread
// that called into the broad phase, never from inside a task.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/limits.hpp"
#include "hbp/scenario.hpp"
#include "hbp/task_system.hpp"
#include "pair_sets.hpp"
#include "sanitizers.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::BroadPhaseOptions;
using hbp::Handle;
using hbp::HybridBroadPhase;
using hbp::Pair;
using hbp::test::minus;

// What a test task system saw of the library's calls.
struct ContractLog {
  std::atomic<std::thread::id> caller{};  // the thread calling into the broad phase now
  std::atomic<int> nested_runs{0};        // run() called from inside a task
  std::atomic<int> foreign_runs{0};       // run() called from another thread than `caller`
  std::atomic<long> batches{0};
  std::atomic<long> tasks{0};

  void on_run(std::uint32_t n, bool in_task) {
    if (in_task) ++nested_runs;
    if (std::this_thread::get_id() != caller.load()) ++foreign_runs;
    ++batches;
    tasks += n;
  }
};

thread_local bool t_in_test_task = false;

struct TaskScope {
  TaskScope() { t_in_test_task = true; }
  ~TaskScope() { t_in_test_task = false; }
};

// Runs each batch on `workers` threads of its own plus the caller, the
// tasks claimed in an order shuffled anew for every batch.
class ScrambledThreads final : public hbp::TaskSystem {
 public:
  ScrambledThreads(unsigned workers, ContractLog& log, std::uint64_t seed) : log_(log), rng_(seed) {
    for (unsigned w = 0; w < workers; ++w) threads_.emplace_back([this] { work(); });
  }
  ~ScrambledThreads() override {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

  void run(std::uint32_t n, hbp::TaskFunction fn, void* context) override {
    log_.on_run(n, t_in_test_task);
    {
      // A worker that woke late for the last batch may still be leaving it.
      std::unique_lock<std::mutex> lock(m_);
      all_done_.wait(lock, [&] { return active_ == 0; });
      order_.resize(n);
      std::iota(order_.begin(), order_.end(), 0u);
      std::shuffle(order_.begin(), order_.end(), rng_);
      fn_ = fn;
      context_ = context;
      count_ = n;
      next_ = 0;
      finished_ = 0;
      ++generation_;
    }
    wake_.notify_all();
    drain();
    std::unique_lock<std::mutex> lock(m_);
    all_done_.wait(lock, [&] { return finished_ == count_ && active_ == 0; });
    fn_ = nullptr;
  }
  unsigned concurrency() const override { return static_cast<unsigned>(threads_.size()) + 1; }

 private:
  // Claims and runs tasks of the current batch until none is left.
  void drain() {
    while (true) {
      const std::uint32_t k = next_.fetch_add(1);
      if (k >= count_) return;
      {
        TaskScope scope;
        fn_(context_, order_[k]);
      }
      std::lock_guard<std::mutex> lock(m_);
      if (++finished_ == count_) all_done_.notify_all();
    }
  }
  // A worker joins a batch under the lock (so it reads the batch the caller
  // wrote) and counts as active until it leaves; run() returns only when no
  // worker is active, so none straddles two batches.
  void work() {
    std::uint64_t seen = 0;
    while (true) {
      {
        std::unique_lock<std::mutex> lock(m_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        ++active_;
      }
      drain();
      {
        std::lock_guard<std::mutex> lock(m_);
        --active_;
      }
      all_done_.notify_all();
    }
  }

  ContractLog& log_;
  std::mt19937_64 rng_;
  std::vector<std::thread> threads_;
  std::vector<std::uint32_t> order_;
  std::mutex m_;
  std::condition_variable wake_, all_done_;
  bool stop_ = false;
  std::uint64_t generation_ = 0;
  hbp::TaskFunction fn_ = nullptr;
  void* context_ = nullptr;
  std::uint32_t count_ = 0;
  std::atomic<std::uint32_t> next_{0};
  std::uint32_t finished_ = 0;  // under m_
  unsigned active_ = 0;         // workers in a batch, under m_
};

// Every task on the calling thread, last index first, while claiming four
// threads: the library splits its work as for four.
class ReverseSerial final : public hbp::TaskSystem {
 public:
  explicit ReverseSerial(ContractLog& log) : log_(log) {}
  void run(std::uint32_t n, hbp::TaskFunction fn, void* context) override {
    log_.on_run(n, t_in_test_task);
    TaskScope scope;
    for (std::uint32_t i = n; i-- > 0;) fn(context, i);
  }
  unsigned concurrency() const override { return 4; }

 private:
  ContractLog& log_;
};

// The systems under test, by name; each broad phase gets its options.
struct Systems {
  ContractLog scrambled_log, reverse_log;
  ScrambledThreads scrambled{3, scrambled_log, 17};
  ReverseSerial reverse{reverse_log};
  hbp::SerialTaskSystem serial;
  hbp::TbbTaskSystem tbb2{2};

  struct Config {
    std::string name;
    BroadPhaseOptions options;
  };
  std::vector<Config> configs(BroadPhaseOptions base) {
    std::vector<Config> out;
    auto with = [&](std::string name, unsigned threads, hbp::TaskSystem* tasks) {
      BroadPhaseOptions o = base;
      o.threads = threads;
      o.task_system = tasks;
      out.push_back({std::move(name), o});
    };
    with("tbb-arena-1", 1, nullptr);
    with("tbb-arena-2", 2, nullptr);
    with("serial", 0, &serial);
    with("tbb-task-system-2", 0, &tbb2);
    with("scrambled-threads", 0, &scrambled);
    with("reverse", 0, &reverse);
    return out;
  }
  // Marks the calling thread as the one calling into the broad phases.
  void calling_from_here() {
    scrambled_log.caller = std::this_thread::get_id();
    reverse_log.caller = std::this_thread::get_id();
  }
  void expect_contract_kept() {
    for (const ContractLog* log : {&scrambled_log, &reverse_log}) {
      EXPECT_EQ(log->nested_runs.load(), 0) << "run() called from inside a task";
      EXPECT_EQ(log->foreign_runs.load(), 0) << "run() called off the calling thread";
      EXPECT_GT(log->batches.load(), 0) << "the task system was never used";
    }
  }
};

// Every overlapping pair (i < j) of the boxes, sorted: sweep and prune on x.
template <class Included>
std::vector<Pair> sweep_pairs(const std::vector<Aabb>& boxes, std::vector<std::uint32_t> ids, Included&& keep) {
  std::sort(ids.begin(), ids.end(), [&](std::uint32_t x, std::uint32_t y) {
    return boxes[x].min[0] < boxes[y].min[0] || (boxes[x].min[0] == boxes[y].min[0] && x < y);
  });
  std::vector<Pair> out;
  for (std::size_t s = 0; s < ids.size(); ++s) {
    const Aabb& a = boxes[ids[s]];
    for (std::size_t t = s + 1; t < ids.size() && boxes[ids[t]].min[0] <= a.max[0]; ++t) {
      const std::uint32_t i = std::min(ids[s], ids[t]), j = std::max(ids[s], ids[t]);
      if (hbp::overlaps(a, boxes[ids[t]]) && keep(i, j)) out.push_back({i, j});
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---- BroadPhase: randomized edit streams ------------------------------------------

struct Object {
  Aabb box;
  bool is_static;
  std::uint8_t layer;
};

// The world all broad phases of a run are given, and the reference pairs.
struct World {
  std::map<Handle, Object> objects;
  float side;
  std::mt19937_64 rng;

  World(float side_, std::uint64_t seed) : side(side_), rng(seed) {}

  Aabb random_box(float size) {
    std::uniform_real_distribution<float> at(0.0f, side), extent(0.2f * size, size);
    const float x = at(rng), y = at(rng), z = at(rng);
    return {{x, y, z}, {x + extent(rng), y + extent(rng), z + extent(rng)}};
  }
  Aabb nudged(const Aabb& b) {
    std::uniform_real_distribution<float> d(-0.3f, 0.3f);
    const float dx = d(rng), dy = d(rng), dz = d(rng);
    return {{b.min[0] + dx, b.min[1] + dy, b.min[2] + dz}, {b.max[0] + dx, b.max[1] + dy, b.max[2] + dz}};
  }

  // Layers 1 and 2 do not collide; pairs whose handle sum is divisible by 7
  // are filtered out.
  static bool filter(Handle a, Handle b) { return (a + b) % 7 != 0; }

  std::vector<Pair> pairs() const {
    std::vector<Aabb> boxes;
    std::vector<Handle> handles;
    std::vector<const Object*> objs;
    for (const auto& [h, o] : objects) {
      boxes.push_back(o.box);
      handles.push_back(h);
      objs.push_back(&o);
    }
    std::vector<std::uint32_t> ids(boxes.size());
    std::iota(ids.begin(), ids.end(), 0u);
    std::vector<Pair> out;
    for (const Pair p : sweep_pairs(boxes, ids, [&](std::uint32_t i, std::uint32_t j) {
           const Object& a = *objs[i];
           const Object& b = *objs[j];
           if (a.is_static && b.is_static) return false;
           if ((a.layer == 1 && b.layer == 2) || (a.layer == 2 && b.layer == 1)) return false;
           return filter(handles[i], handles[j]);
         }))
      out.push_back({handles[p.a], handles[p.b]});  // map order: handles ascend with the index
    std::sort(out.begin(), out.end());
    return out;
  }
};

// Runs `steps` steps of random edits on every configuration in lockstep:
// each step's pairs, created and removed equal the reference's.
void run_edit_stream(std::uint32_t start_moving, std::uint32_t start_static, float side, float size,
                     std::uint32_t steps, double move_fraction, std::uint32_t churn, std::uint64_t seed,
                     std::uint32_t cell_limit) {
  Systems systems;
  systems.calling_from_here();
  World world(side, seed);
  std::vector<Systems::Config> configs = systems.configs({.engine = "sw", .cell_limit = cell_limit});
  std::vector<std::unique_ptr<BroadPhase>> bps;
  for (const auto& c : configs) {
    bps.push_back(std::make_unique<BroadPhase>(c.options));
    bps.back()->set_collides(1, 2, false);
    bps.back()->set_pair_filter(&World::filter);
  }
  auto add = [&](std::uint32_t count, bool is_static) {
    std::vector<Aabb> boxes(count);
    for (Aabb& b : boxes) b = world.random_box(size);
    const auto layer = static_cast<std::uint8_t>(world.rng() % 3);
    std::vector<Handle> first;
    for (std::size_t k = 0; k < bps.size(); ++k) {
      std::vector<Handle> h = bps[k]->add(boxes, {.is_static = is_static, .layer = layer});
      if (k == 0) first = h;
      ASSERT_EQ(h, first) << configs[k].name << ": handles differ";
    }
    for (std::size_t i = 0; i < first.size(); ++i) world.objects[first[i]] = {boxes[i], is_static, layer};
  };
  add(start_moving, false);
  add(start_static, true);
  std::vector<Pair> previous;
  for (std::uint32_t step = 0; step < steps; ++step) {
    // Moves: a fraction of the moving objects, and now and then a static one.
    std::vector<Handle> moved;
    std::vector<Aabb> to;
    std::bernoulli_distribution pick(move_fraction), pick_static(0.002);
    for (const auto& [h, o] : world.objects)
      if (o.is_static ? pick_static(world.rng) : pick(world.rng)) {
        moved.push_back(h);
        to.push_back(world.nudged(o.box));
      }
    for (auto& bp : bps) bp->move(moved, to);
    for (std::size_t i = 0; i < moved.size(); ++i) world.objects[moved[i]].box = to[i];
    // Churn: remove and add a few objects.
    if (churn && step % 5 == 0) {
      std::vector<Handle> gone;
      for (const auto& [h, o] : world.objects)
        if (world.rng() % world.objects.size() < churn) gone.push_back(h);
      for (auto& bp : bps) bp->remove(gone);
      for (Handle h : gone) world.objects.erase(h);
      add(static_cast<std::uint32_t>(gone.size()), step % 10 == 0);
    }
    const std::vector<Pair> want = world.pairs();
    const std::vector<Pair> created = minus(want, previous), removed = minus(previous, want);
    for (std::size_t k = 0; k < bps.size(); ++k) {
      const hbp::BroadPhaseUpdate& u = bps[k]->update();
      ASSERT_EQ(u.pairs, want) << configs[k].name << ", step " << step;
      ASSERT_EQ(u.created, created) << configs[k].name << ", step " << step;
      ASSERT_EQ(u.removed, removed) << configs[k].name << ", step " << step;
    }
    previous = want;
  }
  systems.expect_contract_kept();
}

// Thousands of steps (hundreds under TSan) with events: moves, static moves,
// adds and removes, layers and a pair filter, the partition in many cells.
TEST(TaskSystem, BroadPhaseLongRunSameUnderEveryTaskSystem) {
  const std::uint32_t steps = hbp::test::kThreadSanitizer ? 300 : 2000;  // sanitizers.hpp
  run_edit_stream(1500, 300, 60.0f, 2.5f, steps, 0.3, 8, 11, 16);
}

// Fewer, larger frames: the parallel paths (edits, engine phase over many
// cells, the pair sort, event diffs) all run.
TEST(TaskSystem, BroadPhaseLargeFramesSameUnderEveryTaskSystem) {
  run_edit_stream(40000, 4000, 150.0f, 3.5f, 12, 1.0, 200, 5, 64);
}

// An exception of a task (the pair filter, on a worker) leaves update()
// unapplied under every task system; the next update reports the same as
// the reference.
TEST(TaskSystem, TaskExceptionIsRethrownAndChangesNothing) {
  Systems systems;
  systems.calling_from_here();
  World world(120.0f, 9);
  std::vector<Aabb> boxes(30000);
  for (Aabb& b : boxes) b = world.random_box(3.0f);
  for (const auto& c : systems.configs({.engine = "sw", .cell_limit = 64})) {
    BroadPhase bp(c.options);
    const std::vector<Handle> h = bp.add(boxes);
    const std::vector<Pair> before = bp.update().pairs;
    ASSERT_FALSE(before.empty());
    std::atomic<int> calls{0};
    bp.set_pair_filter([&](Handle, Handle) -> bool {
      if (++calls == 5000) throw std::runtime_error("filter failed");
      return true;
    });
    std::vector<Aabb> moved(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) moved[i] = world.nudged(boxes[i]);
    bp.move(h, moved);
    EXPECT_THROW(bp.update(), std::runtime_error) << c.name;
    EXPECT_EQ(bp.last_update().pairs, before) << c.name;
    bp.set_pair_filter({});
    const hbp::BroadPhaseUpdate& u = bp.update();
    std::vector<std::uint32_t> ids(moved.size());
    std::iota(ids.begin(), ids.end(), 0u);
    std::vector<Pair> want;
    for (const Pair p : sweep_pairs(moved, ids, [](std::uint32_t, std::uint32_t) { return true; }))
      want.push_back({h[p.a], h[p.b]});
    std::sort(want.begin(), want.end());
    EXPECT_EQ(u.pairs, want) << c.name;
    EXPECT_EQ(u.created, minus(want, before)) << c.name;
    EXPECT_EQ(u.removed, minus(before, want)) << c.name;
  }
  systems.expect_contract_kept();
}

// ---- HybridBroadPhase: the paper scene ---------------------------------------------

std::vector<Pair> reference_pairs(const hbp::BoxArray& boxes) {
  std::vector<Aabb> v(boxes.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = boxes.get(i);
  std::vector<std::uint32_t> ids(v.size());
  std::iota(ids.begin(), ids.end(), 0u);
  return sweep_pairs(v, ids, [](std::uint32_t, std::uint32_t) { return true; });
}

// Sorted and cell-order output, streamed and not: every configuration
// gives the first one's list exactly (cell order included), which is the
// reference's pairs; the ordered sink sees cells 0, 1, 2 ... once each and
// their pairs make up the list in order.
TEST(TaskSystem, HybridPaperSceneSameUnderEveryTaskSystem) {
  Systems systems;
  systems.calling_from_here();
  constexpr int kFrames = 4;
  std::vector<hbp::BoxArray> frames(kFrames);
  std::vector<std::vector<Pair>> wants(kFrames);
  hbp::Scenario scene({.kind = hbp::ScenarioKind::Paper, .n = 60000, .seed = 4});
  for (int f = 0; f < kFrames; ++f) {
    scene.compute_boxes(frames[f]);
    wants[f] = reference_pairs(frames[f]);
    scene.step();
  }
  for (const bool sorted : {true, false}) {
    for (const bool streamed : {false, true}) {
      std::vector<Systems::Config> configs = systems.configs({.engine = "sw", .sorted = sorted});
      std::vector<std::unique_ptr<HybridBroadPhase>> bps;
      for (const auto& c : configs) bps.push_back(std::make_unique<HybridBroadPhase>(c.options));
      for (int f = 0; f < kFrames; ++f) {
        const hbp::BoxArray& boxes = frames[f];
        const std::vector<Pair>& want = wants[f];
        std::vector<Pair> first;
        for (std::size_t k = 0; k < bps.size(); ++k) {
          std::vector<Pair> from_sink;
          std::uint32_t next_cell = 0;
          std::atomic<std::uint64_t> consumed{0};
          hbp::PairSink sink, consumer;
          if (streamed) {
            sink = [&](std::uint32_t cell, const Pair* p, std::size_t n) {
              ASSERT_EQ(cell, next_cell) << configs[k].name;
              ++next_cell;
              from_sink.insert(from_sink.end(), p, p + n);
            };
            consumer = [&](std::uint32_t, const Pair*, std::size_t n) { consumed += n; };
          }
          const std::vector<Pair>& got = bps[k]->update(boxes, sink, consumer);
          if (k == 0) {
            first = got;
            std::vector<Pair> canonical = got;
            std::sort(canonical.begin(), canonical.end());
            ASSERT_EQ(canonical, want) << "frame " << f;
            if (sorted) {
              ASSERT_EQ(got, want);
            }
          }
          ASSERT_EQ(got, first) << configs[k].name << ", frame " << f << (sorted ? ", sorted" : ", cell order")
                                << (streamed ? ", streamed" : "");
          ASSERT_GT(bps[k]->stats().cells, 1u);
          if (streamed) {
            ASSERT_EQ(next_cell, bps[k]->stats().cells) << configs[k].name;
            ASSERT_EQ(consumed.load(), got.size()) << configs[k].name;
            if (!sorted) {
              ASSERT_EQ(from_sink, got) << configs[k].name;
            }
          }
        }
      }
    }
  }
  systems.expect_contract_kept();
}

// CapacityExceeded thrown inside the cell tasks (max_pairs) propagates from
// update() under every task system, and the instance then runs a smaller
// frame exactly.
TEST(TaskSystem, CapacityExceededInsideTasksLeavesTheInstanceUsable) {
  Systems systems;
  systems.calling_from_here();
  hbp::Scenario scene({.kind = hbp::ScenarioKind::Paper, .n = 60000, .seed = 2});
  hbp::BoxArray boxes, few;
  scene.compute_boxes(boxes);
  for (std::size_t i = 0; i < 20000; ++i) few.push_back(boxes.get(i));
  const std::vector<Pair> all = reference_pairs(boxes), want_few = reference_pairs(few);
  const std::uint64_t limit = all.size() / 2;
  ASSERT_LT(want_few.size(), limit);
  for (const auto& c : systems.configs({.engine = "sw", .max_pairs = limit})) {
    HybridBroadPhase bp(c.options);
    EXPECT_THROW(bp.update(boxes), hbp::CapacityExceeded) << c.name;
    EXPECT_EQ(bp.update(few), want_few) << c.name;
    EXPECT_THROW(bp.update(boxes), hbp::CapacityExceeded) << c.name;
    EXPECT_EQ(bp.update(few), want_few) << c.name;
  }
  systems.expect_contract_kept();
}

// ---- The library's task systems -----------------------------------------------------

TEST(TaskSystem, LibrarySystemsRunEveryTaskOnce) {
  hbp::SerialTaskSystem serial;
  hbp::TbbTaskSystem tbb(2);
  EXPECT_EQ(serial.concurrency(), 1u);
  EXPECT_EQ(tbb.concurrency(), 2u);
  for (hbp::TaskSystem* s : {static_cast<hbp::TaskSystem*>(&serial), static_cast<hbp::TaskSystem*>(&tbb)}) {
    std::vector<std::atomic<int>> hits(1000);
    s->run(1000, [](void* c, std::uint32_t i) { ++(*static_cast<std::vector<std::atomic<int>>*>(c))[i]; }, &hits);
    for (std::size_t i = 0; i < hits.size(); ++i) ASSERT_EQ(hits[i].load(), 1) << i;
  }
  std::vector<std::uint32_t> order;
  serial.run(5, [](void* c, std::uint32_t i) { static_cast<std::vector<std::uint32_t>*>(c)->push_back(i); }, &order);
  EXPECT_EQ(order, (std::vector<std::uint32_t>{0, 1, 2, 3, 4}));
  EXPECT_THROW({ hbp::TbbTaskSystem too_many(hbp::kMaxThreads + 1); }, hbp::InvalidInput);
}

}  // namespace
