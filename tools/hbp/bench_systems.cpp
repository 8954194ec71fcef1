// SPDX-License-Identifier: MIT
#include "bench_systems.hpp"

#include <chrono>
#include <cstdio>
#include <utility>

#include "hbp/cell_engine.hpp"
#include "hbp/collision_pipeline.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"

#ifdef HBP_HAVE_BASELINES
#include "hbp/baselines/baseline.hpp"
#endif
#ifdef HBP_HAVE_CUDA
#include "hbp/cuda/axis_sweep.hpp"
#include "hbp/cuda/frame_broadphase.hpp"
#include "hbp/cuda/lbvh.hpp"
#endif
#include "support/clock.hpp"

namespace hbp::cli {
namespace {


// Wall and calling-thread CPU time of one frame.
class Stopwatch {
 public:
  Stopwatch() : wall0_(SteadyClock::now()), cpu0_(thread_cpu_ms()) {}
  // reported: the chosen clock's reading.
  FrameTime stop(BenchClock clock) const {
    FrameTime t;
    t.cpu_ms = thread_cpu_ms() - cpu0_;
    t.wall_ms = ms_since(wall0_);
    t.reported_ms = clock == BenchClock::Cpu ? t.cpu_ms : t.wall_ms;
    return t;
  }

 private:
  SteadyClock::time_point wall0_;
  double cpu0_;
};

constexpr std::uint32_t kCellSizes[] = {1024, 2048, 4096, 8192, 16384};

// A list in cell order as the pair-set check takes it: sorted, in `into`
// (after the timed call).
const std::vector<Pair>& sorted_copy(const std::vector<Pair>& pairs, std::vector<Pair>& into) {
  into = pairs;
  sort_pairs(into);
  return into;
}

#ifdef HBP_HAVE_BASELINES
class BaselineSystem final : public BenchSystem {
 public:
  BaselineSystem(std::unique_ptr<baselines::Baseline> b, BenchClock clock) : b_(std::move(b)), clock_(clock) {}
  std::string key() const override { return b_->name(); }
  std::string label() const override { return b_->label(); }
  bool modelled() const override { return false; }
  bool applies(std::uint32_t) const override { return true; }
  std::string not_applicable_reason(std::uint32_t) const override { return {}; }
  void setup(const BoxArray& boxes) override { b_->setup(boxes); }
  FrameTime update(const BoxArray& boxes) override {
    const Stopwatch watch;
    b_->update(boxes);
    return watch.stop(clock_);
  }
  std::uint64_t raw_pairs() const override { return b_->raw_pairs(); }
  const std::vector<Pair>& exact_pairs() override { return b_->exact_pairs(); }

 private:
  std::unique_ptr<baselines::Baseline> b_;
  BenchClock clock_;
};
#endif

// HybridBroadPhase: measured wall time for the software engine; the
// accelerator's modelled time (cycles of every cell at the model's clock,
// partition excluded as in the paper) for the hardware models. With
// options.sorted false the frame delivers its pairs in cell order (the
// deterministic order of `hbp run`), as every baseline delivers its own
// unordered set; the pair-set check sorts a copy, outside the timed call.
class HybridSystem final : public BenchSystem {
 public:
  HybridSystem(std::string key, std::string label, const BroadPhaseOptions& options, bool modelled,
               BenchClock clock)
      : key_(std::move(key)), label_(std::move(label)), options_(options), modelled_(modelled), clock_(clock) {}
  std::string key() const override { return key_; }
  std::string label() const override { return label_; }
  bool modelled() const override { return modelled_; }
  // With a cell size, the paper runs only worlds larger than a cell.
  bool applies(std::uint32_t n) const override { return options_.cell_limit == 0 || n > options_.cell_limit; }
  std::string not_applicable_reason(std::uint32_t) const override {
    return "n <= cell size " + std::to_string(options_.cell_limit);
  }
  void setup(const BoxArray& boxes) override {
    bp_ = std::make_unique<HybridBroadPhase>(options_);
    bp_->update(boxes);
  }
  FrameTime update(const BoxArray& boxes) override {
    const Stopwatch watch;
    bp_->update(boxes);
    FrameTime t = watch.stop(clock_);
    if (modelled_) t.reported_ms = bp_->stats().modelled_ms;
    return t;
  }
  std::uint64_t raw_pairs() const override { return bp_->stats().candidate_pairs; }
  const std::vector<Pair>& exact_pairs() override {
    return options_.sorted ? bp_->pairs() : sorted_copy(bp_->pairs(), pairs_);
  }

 private:
  std::string key_, label_;
  BroadPhaseOptions options_;
  bool modelled_;
  BenchClock clock_;
  std::unique_ptr<HybridBroadPhase> bp_;
  std::vector<Pair> pairs_;
};

// The whole system: the hybrid broad phase with the narrow phase consuming
// each cell as it leaves the engine (measured). Its pairs are the broad
// phase's, checked like every system's; its time includes the exact shape
// tests.
class PipelineSystem final : public BenchSystem {
 public:
  PipelineSystem(const BroadPhaseOptions& options, BenchClock clock) : options_(options), clock_(clock) {}
  std::string key() const override { return "sw-narrow"; }
  std::string label() const override { return "hybrid sw + narrow"; }
  bool modelled() const override { return false; }
  bool applies(std::uint32_t) const override { return true; }
  std::string not_applicable_reason(std::uint32_t) const override { return ""; }
  void setup(const BoxArray& boxes) override {
    pipeline_ = std::make_unique<CollisionPipeline>(options_);
    run(boxes);
  }
  FrameTime update(const BoxArray& boxes) override {
    const Stopwatch watch;
    run(boxes);
    return watch.stop(clock_);
  }
  std::uint64_t raw_pairs() const override { return pipeline_->stats().candidates; }
  const std::vector<Pair>& exact_pairs() override { return sorted_copy(pipeline_->broad_phase().pairs(), pairs_); }

 private:
  void run(const BoxArray& boxes) {
    const std::vector<Shape>* shapes = current_bench_shapes();
    if (!shapes) throw Error("sw-narrow: the frame has no shapes (recorded box files cannot run the narrow phase)");
    pipeline_->update(boxes, *shapes);
  }

  BroadPhaseOptions options_;
  BenchClock clock_;
  std::unique_ptr<CollisionPipeline> pipeline_;
  std::vector<Pair> pairs_;
};

// One accelerator holding the whole world: the paper's "none" columns, valid
// up to the engine's capacity (1024 area-efficient, 16,384 many-object).
class WholeWorldModel final : public BenchSystem {
 public:
  WholeWorldModel(std::string key, std::string label, std::unique_ptr<CellEngine> engine)
      : key_(std::move(key)), label_(std::move(label)), engine_(std::move(engine)) {}
  std::string key() const override { return key_; }
  std::string label() const override { return label_; }
  bool modelled() const override { return true; }
  bool applies(std::uint32_t n) const override { return n <= engine_->capacity(); }
  std::string not_applicable_reason(std::uint32_t) const override {
    return "n > capacity " + std::to_string(engine_->capacity());
  }
  void setup(const BoxArray& boxes) override { update(boxes); }
  FrameTime update(const BoxArray& boxes) override {
    pairs_.clear();
    const Stopwatch watch;
    const CellRun run = engine_->find_pairs(boxes, pairs_);
    FrameTime t = watch.stop(BenchClock::Wall);
    const auto n = static_cast<std::uint32_t>(boxes.size());
    // The analytic count must equal what the model ran: a disagreement is a
    // model bug the report must not smooth over.
    if (run.cycles != engine_->cycles_for(n))
      throw Error(key_ + ": model ran " + std::to_string(run.cycles) + " cycles for n=" + std::to_string(n) +
                  " but its analytic count is " + std::to_string(engine_->cycles_for(n)));
    raw_ = pairs_.size();
    canonicalize(pairs_);
    t.reported_ms = static_cast<double>(run.cycles) / engine_->clock_hz() * 1e3;
    return t;
  }
  std::uint64_t raw_pairs() const override { return raw_; }
  const std::vector<Pair>& exact_pairs() override { return pairs_; }

 private:
  std::string key_, label_;
  std::unique_ptr<CellEngine> engine_;
  std::vector<Pair> pairs_;
  std::uint64_t raw_ = 0;
};

#ifdef HBP_HAVE_CUDA
// The whole frame on the GPU (docs/gpu.md) and its peers (the one-axis sort
// and sweep of the paper's GPU column, a Karras LBVH), pairs sorted by (a,
// b). The table's time is the device time per frame (CUDA events, boxes
// already on the device); the wall time (host transfers included) goes to
// budgets and ETA.
template <class Gpu>
class GpuSystem final : public BenchSystem {
 public:
  GpuSystem(std::string key, std::string label) : key_(std::move(key)), label_(std::move(label)) {}
  std::string key() const override { return key_; }
  std::string label() const override { return label_ + " (" + cuda::device_name() + ", device time)"; }
  bool modelled() const override { return false; }
  bool applies(std::uint32_t) const override { return true; }
  std::string not_applicable_reason(std::uint32_t) const override { return {}; }
  void setup(const BoxArray& boxes) override {
    cuda::FrameOptions o;
    o.launcher = cuda::Launcher::Device;
    gpu_ = std::make_unique<Gpu>(o);
    if constexpr (requires(Gpu& g) { g.reserve(0u); }) gpu_->reserve(static_cast<std::uint32_t>(boxes.size()));
    pairs_ = &gpu_->update(cuda::lanes_of(boxes));
  }
  FrameTime update(const BoxArray& boxes) override {
    const Stopwatch watch;
    pairs_ = &gpu_->update(cuda::lanes_of(boxes));
    FrameTime t = watch.stop(BenchClock::Wall);
    t.reported_ms = gpu_->info().times.frame_ms;
    return t;
  }
  std::uint64_t raw_pairs() const override { return gpu_->info().pairs; }
  const std::vector<Pair>& exact_pairs() override { return *pairs_; }

 private:
  std::string key_, label_;
  std::unique_ptr<Gpu> gpu_;
  const std::vector<Pair>* pairs_ = nullptr;
};
#endif

bool engine_built(const std::string& name) {
  try {
    (void)make_cell_engine(name);
    return true;
  } catch (const InvalidInput&) {
    return false;
  }
}

}  // namespace

const std::vector<Shape>*& current_bench_shapes() {
  static const std::vector<Shape>* shapes = nullptr;
  return shapes;
}

std::vector<std::string> bench_system_keys() {
  std::vector<std::string> keys = {"bullet-dbvt", "bullet-dbvt-deferred", "bullet-axis-sweep", "cgal", "brute",
                                   "sw", "sw-sorted", "sw-narrow", "cuda", "cuda-axis-sweep", "cuda-lbvh",
                                   "ae-none", "ae-1024", "mo-none"};
  for (std::uint32_t c : kCellSizes) keys.push_back("mo-" + std::to_string(c));
  return keys;
}

std::vector<std::unique_ptr<BenchSystem>> make_bench_systems(const SystemChoice& choice,
                                                             std::vector<std::string>& missing) {
  std::vector<std::unique_ptr<BenchSystem>> systems;
#ifdef HBP_HAVE_BASELINES
  for (const auto& name : baselines::baseline_names())
    systems.push_back(std::make_unique<BaselineSystem>(baselines::make_baseline(name), choice.clock));
#else
  missing.push_back("baselines (built without Bullet/CGAL)");
#endif
  // "sw": pairs in cell order, like the baselines' unordered sets and `hbp
  // run`; "sw-sorted": the library's default, the list sorted by (a, b).
  BroadPhaseOptions sw;
  sw.engine = "sw";
  sw.threads = choice.threads;
  sw.sorted = false;
  systems.push_back(std::make_unique<HybridSystem>("sw", "hybrid sw", sw, false, choice.clock));
  BroadPhaseOptions sw_sorted = sw;
  sw_sorted.sorted = true;
  systems.push_back(std::make_unique<HybridSystem>("sw-sorted", "hybrid sw, sorted", sw_sorted, false, choice.clock));
  if (choice.shapes) systems.push_back(std::make_unique<PipelineSystem>(sw, choice.clock));
#ifdef HBP_HAVE_CUDA
  if (cuda::device_available()) {
    systems.push_back(std::make_unique<GpuSystem<cuda::FrameBroadPhase>>("cuda", "GPU frame"));
    systems.push_back(
        std::make_unique<GpuSystem<cuda::AxisSweep>>("cuda-axis-sweep", "GPU one-axis sort and sweep"));
    systems.push_back(std::make_unique<GpuSystem<cuda::Lbvh>>("cuda-lbvh", "GPU LBVH"));
  } else {
    missing.push_back("GPU frame 'cuda' and its peers 'cuda-axis-sweep', 'cuda-lbvh' (no CUDA device found)");
  }
#else
  missing.push_back("GPU frame 'cuda' and its peers 'cuda-axis-sweep', 'cuda-lbvh' (built without the CUDA room)");
#endif

  if (engine_built("ae")) {
    systems.push_back(std::make_unique<WholeWorldModel>("ae-none", "AE none", make_cell_engine("ae")));
    BroadPhaseOptions ae;
    ae.engine = "ae";
    ae.cell_limit = 1024;
    ae.threads = choice.threads;
    ae.sorted = false;  // modelled time: the list's order costs nothing there
    systems.push_back(std::make_unique<HybridSystem>("ae-1024", "AE 1024", ae, true, choice.clock));
  } else {
    missing.push_back("area-efficient model (engine 'ae' not built)");
  }
  if (engine_built("mo")) {
    systems.push_back(std::make_unique<WholeWorldModel>("mo-none", "MO none", make_cell_engine("mo")));
    for (std::uint32_t c : kCellSizes) {
      BroadPhaseOptions mo;
      mo.engine = "mo";
      mo.cell_limit = c;
      mo.threads = choice.threads;
      mo.sorted = false;
      systems.push_back(std::make_unique<HybridSystem>("mo-" + std::to_string(c), "MO " + std::to_string(c), mo,
                                                         true, choice.clock));
    }
  } else {
    missing.push_back("many-object model (engine 'mo' not built)");
  }
  return systems;
}

}  // namespace hbp::cli
