// SPDX-License-Identifier: MIT
// hbp bench gpu: each frame of a generated scene through the GPU frame
// (device time per stage from CUDA events, the host transfers apart) and
// through our CPU engine ("sw", all cores unless --threads), the GPU's pairs
// compared with the CPU's every frame. --launcher host runs the GPU frame's
// CPU twin instead (its wall time; no device figure). Board power and
// energy per frame need the GPU machine's nvidia-smi: scripts/gpu-check.
#include "bench_gpu.hpp"

#include "bench_sources.hpp"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scenario.hpp"
#include "support/clock.hpp"
#include "support/percentile.hpp"
#ifdef HBP_HAVE_CUDA
#include "hbp/cuda/frame_broadphase.hpp"
#endif

namespace hbp::cli {
namespace {

struct GpuBenchArgs {
  std::string kind = "paper";
  std::string in;  // a recorded scene instead of a generated one
  std::uint32_t n = 1'024'000;
  std::uint32_t frames = 10;
  std::string launcher = "device";
  std::string sweep = "per-reference";
  std::string cell_shape = "columns";
  bool unsorted = false;
  unsigned threads = 0;
  bool json = false;
};

#ifdef HBP_HAVE_CUDA

struct Series {
  std::vector<double> v;
  nlohmann::json summary(bool steady) const {
    std::vector<double> s(v.begin() + (steady && v.size() > 1 ? 1 : 0), v.end());
    return {{"median", median(s)},
            {"p99", percentile(s, 0.99)},
            {"worst", s.empty() ? 0.0 : *std::max_element(s.begin(), s.end())}};
  }
};

void run_bench_gpu(const GpuBenchArgs& a) {
  std::unique_ptr<FrameSource> frames;
  if (a.in.empty())
    frames = std::make_unique<PaperFrames>(a.n, parse_scenario_kind(a.kind));
  else
    frames = std::make_unique<SceneFrames>(a.in);
  const std::uint32_t n = frames->object_count();
  const std::string scene = a.in.empty() ? a.kind : a.in;
  cuda::FrameOptions o;
  o.launcher = a.launcher == "host" ? cuda::Launcher::Host : cuda::Launcher::Device;
  o.sorted = !a.unsorted;
  o.sweep = a.sweep == "block-per-cell" ? cuda::CellSweep::BlockPerCell : cuda::CellSweep::PerReference;
  o.cell_shape = cuda::parse_cell_shape(a.cell_shape);
  BroadPhaseOptions cpu_options;
  cpu_options.threads = a.threads;
  cpu_options.sorted = true;
  HybridBroadPhase cpu(cpu_options);
  const unsigned threads = a.threads ? a.threads : std::max(1u, std::thread::hardware_concurrency());
  o.threads = threads;
  cuda::FrameBroadPhase gpu(o);  // Device without a GPU: "no CUDA device found"
  const auto t_reserve = SteadyClock::now();
  gpu.reserve(n);
  const double reserve_ms = ms_since(t_reserve);

  Series frame, upload, download, cpu_ms, stage[6];
  std::vector<std::uint64_t> pairs_per_frame;
  std::uint64_t steady_allocations = 0, buffer_bytes = 0;
  std::uint32_t mismatched = 0;
  std::vector<Pair> sorted_copy;
  BoxArray boxes;
  for (std::uint32_t f = 0; f < a.frames; ++f) {
    if (f == 0)
      frames->begin_variant(0, boxes);
    else
      frames->next(boxes);
    const std::vector<Pair>& got = gpu.update(cuda::lanes_of(boxes));
    const cuda::FrameInfo& info = gpu.info();
    const cuda::StageTimes& t = info.times;
    frame.v.push_back(t.frame_ms);
    upload.v.push_back(t.upload_ms);
    download.v.push_back(t.download_ms);
    const double st[6] = {t.bounds_ms, t.refs_ms, t.sort_ms, t.count_ms, t.fill_ms, t.order_ms};
    for (int s = 0; s < 6; ++s) stage[s].v.push_back(st[s]);
    if (f > 0) steady_allocations += info.allocations;
    buffer_bytes = std::max<std::uint64_t>(buffer_bytes, info.buffer_bytes);
    pairs_per_frame.push_back(got.size());
    const auto t_cpu = SteadyClock::now();
    const std::vector<Pair>& want = cpu.update(boxes);
    cpu_ms.v.push_back(ms_since(t_cpu));
    const std::vector<Pair>* compared = &got;
    if (a.unsorted) {
      sorted_copy.assign(got.begin(), got.end());
      std::sort(sorted_copy.begin(), sorted_copy.end());
      compared = &sorted_copy;
    }
    if (*compared != want) ++mismatched;
  }

  const bool device = o.launcher == cuda::Launcher::Device;
  const nlohmann::json frame_summary = frame.summary(true), cpu_summary = cpu_ms.summary(true);
  const double gpu_median = frame_summary["median"].get<double>();
  const double cpu_median = cpu_summary["median"].get<double>();
  double mean_pairs = 0;
  for (auto p : pairs_per_frame) mean_pairs += static_cast<double>(p);
  mean_pairs /= static_cast<double>(std::max<std::size_t>(1, pairs_per_frame.size()));
  nlohmann::json stages;
  const char* names[6] = {"bounds", "refs", "sort", "count", "fill", "order"};
  for (int s = 0; s < 6; ++s) stages[names[s]] = median(stage[s].v);
  const nlohmann::json j = {
      {"launcher", device ? "device" : "host"},
      {"device", device ? cuda::device_name() : ""},
      {"time", device ? "device time per frame (CUDA events), host transfers apart" : "wall time of the CPU twin"},
      {"kind", a.in.empty() ? a.kind : "file"},
      {"scene", scene},
      {"objects", n},
      {"frames", a.frames},
      {"order", a.unsorted ? "frame order" : "sorted by (a, b)"},
      {"sweep", a.sweep},
      {"cell_shape", a.cell_shape},
      {"reserve_ms", reserve_ms},
      {"first_frame_ms", frame.v.empty() ? 0.0 : frame.v.front()},
      {"frame_ms", frame_summary},
      {"stage_ms", stages},
      {"upload_ms", median(upload.v)},
      {"download_ms", median(download.v)},
      {"pairs_per_frame", pairs_per_frame},
      {"pairs_per_second", gpu_median > 0 ? mean_pairs / (gpu_median / 1000) : 0.0},
      {"device_memory_bytes", buffer_bytes},
      {"steady_allocations", steady_allocations},
      {"cpu", {{"engine", "sw"}, {"threads", threads}, {"frame_ms", cpu_summary}}},
      {"cpu_over_gpu", gpu_median > 0 ? cpu_median / gpu_median : 0.0},
      {"frames_mismatched", mismatched},
      {"exact", mismatched == 0},
  };
  if (a.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("%s, %u objects, %u frames: %s (%s)\n", scene.c_str(), n, a.frames,
                device ? ("GPU " + cuda::device_name()).c_str() : "the GPU frame's CPU twin, no device figure",
                j["time"].get<std::string>().c_str());
    std::printf("  GPU frame: first %.3f ms, median %.3f, p99 %.3f, worst %.3f; upload %.3f, download %.3f\n",
                j["first_frame_ms"].get<double>(), gpu_median, j["frame_ms"]["p99"].get<double>(),
                j["frame_ms"]["worst"].get<double>(), j["upload_ms"].get<double>(), j["download_ms"].get<double>());
    std::printf("  stages (median ms): bounds %.3f, refs %.3f, sort %.3f, count %.3f, fill %.3f, order %.3f\n",
                stages["bounds"].get<double>(), stages["refs"].get<double>(), stages["sort"].get<double>(),
                stages["count"].get<double>(), stages["fill"].get<double>(), stages["order"].get<double>());
    std::printf("  %.0f pairs per frame, %.3g pairs/s, %.0f MiB of buffers, %llu allocations in steady frames\n",
                mean_pairs, j["pairs_per_second"].get<double>(), static_cast<double>(buffer_bytes) / (1 << 20),
                static_cast<unsigned long long>(steady_allocations));
    std::printf("  CPU engine sw (%u threads): median %.3f ms; CPU / GPU %.1f\n", threads, cpu_median,
                j["cpu_over_gpu"].get<double>());
    std::printf("  pairs equal to sw's in %u of %u frames\n", a.frames - mismatched, a.frames);
  }
  if (mismatched) throw Error("the GPU frame's pairs differ from sw's in " + std::to_string(mismatched) + " frames");
}

#endif

}  // namespace

void add_bench_gpu(CLI::App* bench) {
  auto a = std::make_shared<GpuBenchArgs>();
  CLI::App* cmd = bench->add_subcommand(
      "gpu", "The whole frame on the GPU against our CPU engine, every frame compared: device time per stage, "
             "host transfers apart, pairs/s, device memory (needs a CUDA device; --launcher host: its CPU twin)");
  cmd->add_option("--kind", a->kind, "Scene kind")
      ->check(CLI::IsMember({"paper", "clustered", "flat", "huge", "degenerate"}))
      ->capture_default_str();
  cmd->add_option("--n", a->n, "Objects")->check(CLI::Range(1u, 1u << 26))->capture_default_str();
  cmd->add_option("--in", a->in, "A recorded scene (native .hbps or Broadmark .aabbs) instead of --kind/--n");
  cmd->add_option("--frames", a->frames, "Frames (the first is reported apart)")
      ->check(CLI::Range(1u, 100000u))
      ->capture_default_str();
  cmd->add_option("--launcher", a->launcher, "device, or host: the same kernels on the CPU (no device figure)")
      ->check(CLI::IsMember({"device", "host"}))
      ->capture_default_str();
  cmd->add_option("--sweep", a->sweep, "per-reference, or block-per-cell: the paper's accelerator layout")
      ->check(CLI::IsMember({"per-reference", "block-per-cell"}))
      ->capture_default_str();
  cmd->add_option("--cell-shape", a->cell_shape, "columns (long on the sweep axis), or cubes")
      ->check(CLI::IsMember({"columns", "cubes"}))
      ->capture_default_str();
  cmd->add_flag("--unsorted", a->unsorted, "Pairs in the frame's own order (compared with sw's as a set)");
  cmd->add_option("--threads", a->threads, "CPU threads of the sw engine and the CPU twin (0: all cores)")
      ->capture_default_str();
  cmd->add_flag("--json", a->json, "Print the result as JSON (keys: docs/cli.md)");
  cmd->callback([a] {
#ifdef HBP_HAVE_CUDA
    run_bench_gpu(*a);
#else
    throw Error("hbp bench gpu: this hbp was built without the CUDA room (-DHBP_CUDA=OFF or no nvcc)");
#endif
  });
}

}  // namespace hbp::cli
