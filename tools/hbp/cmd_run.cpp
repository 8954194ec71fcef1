// hbp run: the hybrid system on a generated or recorded scene, per-frame
// timings by stage, modelled accelerator time, pairs, and a summary.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "command_registry.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"
#include "hbp/software_engine.hpp"

namespace hbp::cli {
namespace {

struct RunArgs {
  std::string scene = "paper";
  std::string in;
  std::uint32_t n = 10000;
  std::uint32_t frames = 10;
  std::uint64_t seed = 0;
  std::string engine = "sw";
  std::uint32_t cell_limit = 0;
  unsigned threads = 0;
  bool json = false;
  bool quiet = false;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto idx = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(idx, v.size() - 1)];
}

// Frames come from a scenario or a scene file, behind one small interface.
class FrameSource {
 public:
  explicit FrameSource(const RunArgs& a) {
    if (!a.in.empty()) {
      reader_ = std::make_unique<SceneReader>(a.in);
      frames_ = std::min<std::uint32_t>(a.frames, reader_->info().frame_count);
    } else {
      ScenarioParams p;
      p.kind = parse_scenario_kind(a.scene);
      p.n = a.n;
      p.seed = a.seed;
      p.frames = a.frames;
      scenario_ = std::make_unique<Scenario>(p);
      frames_ = a.frames;
    }
  }
  std::uint32_t frames() const { return frames_; }
  std::size_t objects() const { return reader_ ? reader_->info().object_count : scenario_->size(); }
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

void run(const RunArgs& a) {
  FrameSource source(a);
  HybridBroadPhase bp({.engine = a.engine, .cell_limit = a.cell_limit, .threads = a.threads, .sorted = false});
  const unsigned threads = a.threads ? a.threads : std::max(1u, std::thread::hardware_concurrency());
  nlohmann::json frames = nlohmann::json::array();
  std::vector<double> wall, modelled;
  BoxArray boxes;
  if (!a.json && !a.quiet) {
    std::printf("engine %s (simd %s), cell limit %u, threads %u, %zu objects, %u frames\n", a.engine.c_str(),
                SoftwareEngine::isa(), bp.cell_limit(), threads, source.objects(), source.frames());
    std::printf("%6s %10s %9s %9s %9s %9s %12s %7s %6s %s\n", "frame", "pairs", "wall_ms", "part_ms", "engine_ms",
                "merge_ms", "modelled_ms", "cells", "dup", "maintenance");
  }
  for (std::uint32_t k = 0; k < source.frames(); ++k) {
    source.frame(k, boxes);
    bp.update(boxes);
    const FrameStats& s = bp.stats();
    const bool modelled_engine = s.modelled_cycles > 0 || a.engine.rfind("ae", 0) == 0 ||
                                 a.engine.rfind("mo", 0) == 0 || a.engine.rfind("rtl", 0) == 0;
    wall.push_back(s.wall_ms);
    if (modelled_engine) modelled.push_back(s.modelled_ms);
    nlohmann::json f = {{"frame", k},
                        {"pairs", s.pairs},
                        {"wall_ms", s.wall_ms},
                        {"partition_ms", s.partition_ms},
                        {"engine_ms", s.engine_ms},
                        {"dedup_ms", s.dedup_ms},
                        {"cells", s.cells},
                        {"median_cell", s.median_cell},
                        {"max_cell", s.max_cell},
                        {"rebuilt", s.rebuilt},
                        {"splits", s.splits},
                        {"merges", s.merges},
                        {"duplication", s.duplication},
                        {"modelled_ms", modelled_engine ? nlohmann::json(s.modelled_ms) : nlohmann::json(nullptr)}};
    frames.push_back(f);
    if (!a.json && !a.quiet) {
      char model[32] = "-";
      if (modelled_engine) std::snprintf(model, sizeof model, "%.4f", s.modelled_ms);
      std::printf("%6u %10llu %9.3f %9.3f %9.3f %9.3f %12s %7u %6.3f %s+%us-%um\n", k,
                  static_cast<unsigned long long>(s.pairs), s.wall_ms, s.partition_ms, s.engine_ms, s.dedup_ms, model,
                  s.cells, s.duplication, s.rebuilt ? "rebuild" : "keep", s.splits, s.merges);
    }
  }
  const double med = percentile(wall, 0.5), p95 = percentile(wall, 0.95);
  if (a.json) {
    nlohmann::json params = {{"scene", a.in.empty() ? a.scene : std::string("file")},
                             {"in", a.in},
                             {"n", source.objects()},
                             {"frames", source.frames()},
                             {"seed", a.seed},
                             {"engine", a.engine},
                             {"cell_limit", bp.cell_limit()},
                             {"threads", threads},
                             {"simd", SoftwareEngine::isa()}};
    nlohmann::json summary = {{"median_wall_ms", med},
                              {"p95_wall_ms", p95},
                              {"median_modelled_ms", modelled.empty() ? nlohmann::json(nullptr)
                                                                      : nlohmann::json(percentile(modelled, 0.5))}};
    std::printf("%s\n", nlohmann::json{{"params", params}, {"frames", frames}, {"summary", summary}}.dump(1).c_str());
  } else {
    std::printf("summary: wall (measured) median %.3f ms, p95 %.3f ms", med, p95);
    if (!modelled.empty()) std::printf("; accelerator (modelled) median %.4f ms", percentile(modelled, 0.5));
    std::printf("\n");
  }
}

const RegisterCommand reg([](CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "Run the hybrid broad phase on a scene, frame by frame");
  cmd->add_option("--scene", args->scene, "Scenario kind: paper, clustered, flat, huge, degenerate")
      ->capture_default_str();
  cmd->add_option("--in", args->in, "Recorded scene file (native or Broadmark) instead of --scene");
  cmd->add_option("--n", args->n, "Objects")->capture_default_str();
  cmd->add_option("--frames", args->frames, "Frames")->capture_default_str();
  cmd->add_option("--seed", args->seed, "Scenario seed (variant)")->capture_default_str();
  cmd->add_option("--engine", args->engine, "Cell engine: sw, sw-allpairs, brute, ae, mo, ae-sim, mo-sim, rtl-ae, rtl-mo")
      ->capture_default_str();
  cmd->add_option("--cell-limit", args->cell_limit, "Objects per cell (0: engine default)")->capture_default_str();
  cmd->add_option("--threads", args->threads, "Threads (0: all cores)")->capture_default_str();
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->add_flag("--quiet", args->quiet, "Only the summary");
  cmd->callback([args] { run(*args); });
});

}  // namespace
}  // namespace hbp::cli
