// SPDX-License-Identifier: MIT
// hbp run: the hybrid system on a generated or recorded scene, per-frame
// timings by stage, modelled accelerator time, pairs, and a summary.
#include <nlohmann/json.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cmd_distributed.hpp"
#include "run_request.hpp"
#include "command_registry.hpp"
#include "option_checks.hpp"
#include "hbp/collision_pipeline.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"
#include "hbp/software_engine.hpp"
#include "support/clock.hpp"
#include "support/percentile.hpp"

namespace hbp::cli {
namespace {

struct RunArgs : RunRequest {
  bool narrow = false;
  double depth_tolerance = narrow::kContactDepthTolerance;
  bool depth_tolerance_given = false;
  bool cost_splits = false;
  bool distributed = false;
  bool reserve = true;
};

// Frames come from a scenario or a scene file, behind one small interface.
class FrameSource {
 public:
  explicit FrameSource(const RunArgs& a) {
    if (!a.in.empty()) {
      reader_ = std::make_unique<SceneReader>(a.in);
      if (reader_->info().frame_count == 0)
        throw InvalidInput(a.in + ": the scene has no frames: nothing to run");
      frames_ = std::min<std::uint32_t>(a.frames, reader_->info().frame_count);
    } else {
      scenario_ = std::make_unique<Scenario>(scenario_params(a));
      frames_ = a.frames;
    }
  }
  std::uint32_t frames() const { return frames_; }
  std::size_t objects() const { return reader_ ? reader_->info().object_count : scenario_->size(); }
  const std::vector<Shape>* shapes() const { return scenario_ ? &scenario_->shapes() : nullptr; }
  void frame(std::uint32_t k, BoxArray& out) {
    if (reader_) {
      reader_->read_frame(k, out);
      return;
    }
    if (k > 0) scenario_->step();
    scenario_->compute_boxes(out);
  }

 private:
  std::unique_ptr<SceneReader> reader_;
  std::unique_ptr<Scenario> scenario_;
  std::uint32_t frames_ = 0;
};

// The narrow phase's figures for one frame: the pipelined whole, and the two
// stages run one after the other on the same frame for comparison.
struct NarrowFrame {
  std::uint64_t contacts = 0;
  double pipelined_ms = 0, narrow_cpu_ms = 0, tail_ms = 0, sequential_broad_ms = 0, sequential_narrow_ms = 0;
};

NarrowFrame run_narrow(CollisionPipeline& cp, HybridBroadPhase& reference, const NarrowPhase& narrow,
                       const BoxArray& boxes, const std::vector<Shape>& shapes) {
  NarrowFrame f;
  cp.update(boxes, shapes);
  f.contacts = cp.stats().contacts;
  f.pipelined_ms = cp.stats().wall_ms;
  f.narrow_cpu_ms = cp.stats().narrow_cpu_ms;
  f.tail_ms = cp.stats().tail_ms;
  reference.update(boxes);
  f.sequential_broad_ms = reference.stats().wall_ms;
  const auto& pairs = reference.pairs();
  const auto t = SteadyClock::now();
  tbb::enumerable_thread_specific<std::vector<Contact>> outs;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pairs.size(), 256), [&](const auto& r) {
    narrow.process(shapes, pairs.data() + r.begin(), r.size(), outs.local());
  });
  f.sequential_narrow_ms = ms_since(t);
  std::uint64_t hits = 0;
  for (const auto& o : outs) hits += o.size();
  if (hits != f.contacts)
    throw Error("narrow phase: pipelined run found " + std::to_string(f.contacts) + " contacts, sequential run " +
                std::to_string(hits));
  return f;
}

void run(const RunArgs& a) {
  if (a.depth_tolerance_given && !a.narrow) throw InvalidInput("--depth-tolerance needs --narrow");
  if (a.distributed) {
    if (a.narrow || a.cost_splits) throw InvalidInput("--distributed does not take --narrow or --cost-splits");
    return run_distributed(a);
  }
  FrameSource source(a);
  if (a.narrow && !source.shapes())
    throw InvalidInput("--narrow needs shapes: use --scene (scene files hold boxes only)");
  std::unique_ptr<tbb::global_control> limit;
  if (a.threads) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);
  std::unique_ptr<CollisionPipeline> pipeline;
  std::unique_ptr<HybridBroadPhase> reference;
  const NarrowOptions narrow_options{.depth_tolerance = a.depth_tolerance};
  const NarrowPhase narrow(narrow_options);
  if (a.narrow) {
    pipeline = std::make_unique<CollisionPipeline>(
        BroadPhaseOptions{.engine = a.engine, .cell_limit = a.cell_limit, .threads = a.threads}, narrow_options);
    reference = std::make_unique<HybridBroadPhase>(
        BroadPhaseOptions{.engine = a.engine, .cell_limit = a.cell_limit, .threads = a.threads, .sorted = false});
  }
  std::vector<double> pipelined, sequential;
  HybridBroadPhase bp({.engine = a.engine,
                      .cell_limit = a.cell_limit,
                      .threads = a.threads,
                      .sorted = false,
                      .cost_splits = a.cost_splits});
  const unsigned threads = a.threads ? a.threads : std::max(1u, std::thread::hardware_concurrency());
  nlohmann::json frames = nlohmann::json::array();
  std::vector<double> wall, modelled, partition, engine, merge, sort, pairs_per_s;
  BoxArray boxes;
  if (!a.json && !a.quiet) {
    std::printf("engine %s (simd %s), cell limit %u, threads %u, %zu objects, %u frames\n", a.engine.c_str(),
                SoftwareEngine::isa(), bp.cell_limit(), threads, source.objects(), source.frames());
    std::printf("%6s %10s %9s %9s %9s %9s %9s %12s %7s %6s %s\n", "frame", "pairs", "wall_ms", "part_ms",
                "engine_ms", "merge_ms", "sort_ms", "modelled_ms", "cells", "dup", "maintenance");
  }
  // The scene's object count is known before frame 0: the memory the
  // frames keep is provisioned once frame 0's boxes are read, as an engine
  // does at level load, and timed apart from the frames (--no-reserve:
  // frame 0 provisions it). (Before the read, the first frame came out a
  // few ms slower warm.)
  double reserve_ms = 0;
  for (std::uint32_t k = 0; k < source.frames(); ++k) {
    source.frame(k, boxes);
    if (k == 0 && a.reserve) {
      const auto reserve_start = SteadyClock::now();
      bp.reserve(source.objects());
      if (a.narrow) {
        pipeline->reserve(source.objects());
        reference->reserve(source.objects());
      }
      reserve_ms = ms_since(reserve_start);
    }
    bp.update(boxes);
    const FrameStats& s = bp.stats();
    NarrowFrame nf;
    if (a.narrow) {
      nf = run_narrow(*pipeline, *reference, narrow, boxes, *source.shapes());
      pipelined.push_back(nf.pipelined_ms);
      sequential.push_back(nf.sequential_broad_ms + nf.sequential_narrow_ms);
    }
    const bool modelled_engine = s.modelled_cycles > 0 || a.engine.rfind("ae", 0) == 0 ||
                                 a.engine.rfind("mo", 0) == 0 || a.engine.rfind("rtl", 0) == 0;
    wall.push_back(s.wall_ms);
    partition.push_back(s.partition_ms);
    engine.push_back(s.engine_ms);
    merge.push_back(s.merge_ms);
    sort.push_back(s.sort_ms);
    pairs_per_s.push_back(s.wall_ms > 0 ? static_cast<double>(s.pairs) / (s.wall_ms * 1e-3) : 0.0);
    if (modelled_engine) modelled.push_back(s.modelled_ms);
    nlohmann::json f = {{"frame", k},
                        {"pairs", s.pairs},
                        {"wall_ms", s.wall_ms},
                        {"partition_ms", s.partition_ms},
                        {"engine_ms", s.engine_ms},
                        {"merge_ms", s.merge_ms},
                        {"sort_ms", s.sort_ms},
                        // merge_ms + sort_ms, under the key outside programs read
                        // (the ownership test itself is inside engine_ms)
                        {"dedup_ms", s.after_engines_ms()},
                        {"one_cell", s.one_cell},
                        {"cells", s.cells},
                        {"median_cell", s.median_cell},
                        {"max_cell", s.max_cell},
                        {"rebuilt", s.rebuilt},
                        {"rebuilt_subtrees", s.rebuilt_subtrees},
                        {"rebuilt_entries", s.rebuilt_entries},
                        {"splits", s.splits},
                        {"merges", s.merges},
                        {"duplication", s.duplication},
                        {"modelled_ms", modelled_engine ? nlohmann::json(s.modelled_ms) : nlohmann::json(nullptr)}};
    if (a.narrow) {
      f["narrow"] = {{"contacts", nf.contacts},
                     {"pipelined_wall_ms", nf.pipelined_ms},
                     {"narrow_cpu_ms", nf.narrow_cpu_ms},
                     {"tail_ms", nf.tail_ms},
                     {"sequential_broad_ms", nf.sequential_broad_ms},
                     {"sequential_narrow_ms", nf.sequential_narrow_ms}};
    }
    frames.push_back(f);
    if (!a.json && !a.quiet) {
      char model[32] = "-";
      if (modelled_engine) std::snprintf(model, sizeof model, "%.4f", s.modelled_ms);
      std::printf("%6u %10llu %9.3f %9.3f %9.3f %9.3f %9.3f %12s %7u %6.3f %s+%us-%um+%ur\n", k,
                  static_cast<unsigned long long>(s.pairs), s.wall_ms, s.partition_ms, s.engine_ms, s.merge_ms,
                  s.sort_ms, model, s.cells, s.duplication,
                  s.one_cell ? "one-cell" : (s.rebuilt ? "rebuild" : "keep"), s.splits, s.merges, s.rebuilt_subtrees);
      if (a.narrow)
        std::printf("       narrow: %llu contacts of %llu candidates; pipelined %.3f ms (narrow CPU %.3f ms) vs "
                    "broad %.3f + narrow %.3f ms one after the other\n",
                    static_cast<unsigned long long>(nf.contacts), static_cast<unsigned long long>(s.pairs),
                    nf.pipelined_ms, nf.narrow_cpu_ms, nf.sequential_broad_ms, nf.sequential_narrow_ms);
    }
  }
  const double med = percentile(wall, 0.5), p95 = percentile(wall, 0.95), p99 = percentile(wall, 0.99);
  const double first = wall.empty() ? 0.0 : wall.front();
  const auto worst_at = static_cast<std::size_t>(std::max_element(wall.begin(), wall.end()) - wall.begin());
  const double worst = wall.empty() ? 0.0 : wall[worst_at];
  if (a.json) {
    nlohmann::json params = {{"scene", a.in.empty() ? a.scene : std::string("file")},
                             {"in", a.in},
                             {"n", source.objects()},
                             {"frames", source.frames()},
                             {"seed", a.seed},
                             {"engine", a.engine},
                             {"cell_limit", bp.cell_limit()},
                             {"threads", threads},
                             {"reserve", a.reserve},
                             {"cost_splits", a.cost_splits},
                             {"simd", SoftwareEngine::isa()}};
    if (a.narrow) params["depth_tolerance"] = a.depth_tolerance;
    nlohmann::json summary = {{"median_wall_ms", med},
                              {"p95_wall_ms", p95},
                              {"p99_wall_ms", p99},
                              {"first_wall_ms", first},
                              {"reserve_ms", reserve_ms},
                              {"max_wall_ms", worst},
                              {"max_wall_frame", worst_at},
                              {"median_partition_ms", percentile(partition, 0.5)},
                              {"median_engine_ms", percentile(engine, 0.5)},
                              {"median_merge_ms", percentile(merge, 0.5)},
                              {"median_sort_ms", percentile(sort, 0.5)},
                              {"median_pairs_per_s", percentile(pairs_per_s, 0.5)},
                              {"median_modelled_ms", modelled.empty() ? nlohmann::json(nullptr)
                                                                      : nlohmann::json(percentile(modelled, 0.5))}};
    if (a.narrow) {
      summary["median_pipelined_wall_ms"] = percentile(pipelined, 0.5);
      summary["median_sequential_wall_ms"] = percentile(sequential, 0.5);
    }
    std::printf("%s\n", nlohmann::json{{"params", params}, {"frames", frames}, {"summary", summary}}.dump(1).c_str());
  } else {
    std::printf("summary: wall (measured) median %.3f ms, first %.3f ms, worst %.3f ms (frame %zu), p95 %.3f ms, "
                "p99 %.3f ms; %.3g pairs/s (median)\n",
                med, first, worst, worst_at, p95, p99, percentile(pairs_per_s, 0.5));
    if (a.reserve) std::printf("reserve (before frame 0, measured): %.3f ms\n", reserve_ms);
    std::printf("stages (medians, measured): partition %.3f ms, engine %.3f ms, merge %.3f ms, sort %.3f ms",
                percentile(partition, 0.5), percentile(engine, 0.5), percentile(merge, 0.5), percentile(sort, 0.5));
    if (!modelled.empty()) std::printf("; accelerator (modelled) median %.4f ms", percentile(modelled, 0.5));
    std::printf("\n");
    if (a.narrow)
      std::printf("full pipeline (measured): broad + narrow overlapped median %.3f ms, one after the other %.3f ms\n",
                  percentile(pipelined, 0.5), percentile(sequential, 0.5));
  }
}

const RegisterCommand reg([](CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "Run the hybrid broad phase on a scene, frame by frame");
  cmd->add_option("--scene", args->scene, "Scenario kind: paper, clustered, flat, huge, degenerate")
      ->capture_default_str();
  cmd->add_option("--in", args->in, "Recorded scene file (native or Broadmark) instead of --scene");
  cmd->add_option("--n", args->n, "Objects")->capture_default_str();
  cmd->add_option("--frames", args->frames, "Frames")->check(at_least_one())->capture_default_str();
  cmd->add_option("--seed", args->seed, "Scenario seed (variant)")->capture_default_str();
  cmd->add_option("--engine", args->engine, "Cell engine: sw, sw-allpairs, brute, ae, mo, ae-sim, mo-sim, rtl-ae, rtl-mo, cuda-host, cuda")
      ->capture_default_str();
  cmd->add_option("--cell-limit", args->cell_limit, "Objects per cell (0: engine default)")->capture_default_str();
  cmd->add_option("--threads", args->threads, "Threads (0: all cores)")->check(threads_range())->capture_default_str();
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->add_flag("--cost-splits", args->cost_splits,
                "Hardware engines: split cells below the limit while that lowers the modelled cycles");
  cmd->add_flag("--quiet", args->quiet, "Only the summary");
  cmd->add_flag("--reserve,!--no-reserve", args->reserve,
                "Provision the frames' memory for the scene's object count before frame 0 (HybridBroadPhase::reserve; "
                "its time is reserve_ms, not part of any frame); --no-reserve: frame 0 provisions it")
      ->capture_default_str();
  cmd->add_flag("--distributed", args->distributed,
                "Over MPI ranks (start under mpirun; docs/distributed.md); JSON adds per-rank counts and times");
  cmd->add_flag("--narrow", args->narrow,
                "Also run the narrow phase, overlapped with the broad phase (and, for comparison, after it)");
  CLI::Option* depth_tolerance =
      cmd->add_option("--depth-tolerance", args->depth_tolerance,
                      "With --narrow: relative tolerance of contact depths (NarrowOptions::depth_tolerance)")
          ->capture_default_str();
  cmd->callback([args, depth_tolerance] {
    args->depth_tolerance_given = depth_tolerance->count() > 0;
    run(*args);
  });
});

}  // namespace
}  // namespace hbp::cli
