// SPDX-License-Identifier: MIT
// Scene generation and scene-file throughput, in objects per second
// (items_per_second). Files go to the temp directory and stay in the page
// cache, so the I/O figures are the format's CPU cost (validation, Broadmark's
// transposition, syscalls), not the disk's speed.
//
//   bench_scene_io --benchmark_min_time=0.2
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"

namespace {

constexpr std::uint32_t kFramesPerFile = 4;

std::string temp_scene(const char* tag, std::int64_t n) {
  return (std::filesystem::temp_directory_path() /
          ("hbp_bench_" + std::to_string(::getpid()) + "_" + tag + "_" + std::to_string(n)))
      .string();
}

// One frame: integrate every object, then its tight AABB (what `hbp scene
// gen` does per frame before writing).
void BM_GenerateFrame(benchmark::State& state, hbp::ScenarioKind kind) {
  hbp::ScenarioParams p;
  p.kind = kind;
  p.n = static_cast<std::uint32_t>(state.range(0));
  hbp::Scenario scenario(p);
  hbp::BoxArray boxes;
  for (auto _ : state) {
    scenario.step();
    scenario.compute_boxes(boxes);
    benchmark::DoNotOptimize(boxes.min(0));
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK_CAPTURE(BM_GenerateFrame, paper, hbp::ScenarioKind::Paper)->Arg(10'000)->Arg(100'000)->UseRealTime();
BENCHMARK_CAPTURE(BM_GenerateFrame, clustered, hbp::ScenarioKind::Clustered)->Arg(100'000)->UseRealTime();

// Building a scenario: random shapes, sizes, poses, velocities.
void BM_CreateScenario(benchmark::State& state) {
  hbp::ScenarioParams p;
  p.n = static_cast<std::uint32_t>(state.range(0));
  for (auto _ : state) {
    hbp::Scenario scenario(p);
    benchmark::DoNotOptimize(scenario.shapes().data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_CreateScenario)->Arg(100'000)->UseRealTime();

hbp::BoxArray paper_frame(std::uint32_t n) {
  hbp::ScenarioParams p;
  p.n = n;
  hbp::BoxArray boxes;
  hbp::Scenario(p).compute_boxes(boxes);
  return boxes;
}

// Writing a whole file of kFramesPerFile frames (create, header, frames,
// close) per iteration, so the file does not grow with the iteration count.
void BM_Write(benchmark::State& state, hbp::SceneFormat format) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const hbp::BoxArray frame = paper_frame(n);
  const std::string path = temp_scene(hbp::scene_format_name(format), n);
  const hbp::Aabb world{{0, 0, 0}, {1e4f, 1e4f, 1e4f}};
  for (auto _ : state) {
    hbp::SceneWriter writer(path, format, n, world);
    for (std::uint32_t k = 0; k < kFramesPerFile; ++k) writer.write_frame(frame);
    writer.close();
  }
  std::filesystem::remove(path);
  state.SetItemsProcessed(state.iterations() * kFramesPerFile * n);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() *
                                                    hbp::scene_file_bytes(format, n, kFramesPerFile)));
}
BENCHMARK_CAPTURE(BM_Write, native, hbp::SceneFormat::Native)->Arg(100'000)->UseRealTime();
BENCHMARK_CAPTURE(BM_Write, broadmark, hbp::SceneFormat::Broadmark)->Arg(100'000)->UseRealTime();

// Reading (and validating) every frame of a file.
void BM_Read(benchmark::State& state, hbp::SceneFormat format) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const std::string path = temp_scene(hbp::scene_format_name(format), n);
  {
    const hbp::BoxArray frame = paper_frame(n);
    hbp::SceneWriter writer(path, format, n, hbp::Aabb{{0, 0, 0}, {1e4f, 1e4f, 1e4f}});
    for (std::uint32_t k = 0; k < kFramesPerFile; ++k) writer.write_frame(frame);
    writer.close();
  }
  hbp::SceneReader reader(path);
  hbp::BoxArray boxes;
  for (auto _ : state) {
    for (std::uint32_t k = 0; k < kFramesPerFile; ++k) reader.read_frame(k, boxes);
    benchmark::DoNotOptimize(boxes.max(2));
  }
  std::filesystem::remove(path);
  state.SetItemsProcessed(state.iterations() * kFramesPerFile * n);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() *
                                                    hbp::scene_file_bytes(format, n, kFramesPerFile)));
}
BENCHMARK_CAPTURE(BM_Read, native, hbp::SceneFormat::Native)->Arg(100'000)->UseRealTime();
BENCHMARK_CAPTURE(BM_Read, broadmark, hbp::SceneFormat::Broadmark)->Arg(100'000)->UseRealTime();

}  // namespace
