// SPDX-License-Identifier: MIT
// hbp-gpu-bench: the GPU frame (hbp::cuda::FrameBroadPhase), or with
// --system axis-sweep the one-axis sort-and-sweep peer (hbp::cuda::AxisSweep)
// or --system lbvh the Karras-style LBVH peer (hbp::cuda::Lbvh), on a
// scenario, frame by frame: device time per stage (CUDA events) with the host
// transfers apart, checked against the CPU launcher of the same kernels
// (identical lists) every frame, or with --check-every K every K-th frame and
// the last (K >= frames: the last alone), and, independently, by brute force
// for a sample of objects against all others in the first and last frames.
// Writes one JSON object (--json) for scripts/gpu-check's report. With
// --sustain S, the last frame's boxes are then kept in device memory and the
// frame re-run through the device entry (update_device) back to back for S
// seconds, so that board power sampled in that window (its wall-clock bounds
// are in the JSON) is the power of steady frames alone. Exits 1 on any
// mismatch.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <cuda_runtime.h>

#include "hbp/box_array.hpp"
#include "hbp/cuda/axis_sweep.hpp"
#include "hbp/cuda/frame_broadphase.hpp"
#include "hbp/cuda/lbvh.hpp"
#include "hbp/error.hpp"
#include "hbp/scenario.hpp"

namespace {

struct Args {
  std::string kind = "paper";
  bool axis_sweep = false;  // --system axis-sweep
  bool lbvh = false;        // --system lbvh
  std::uint32_t n = 1'024'000;
  std::uint32_t frames = 30;
  std::uint32_t check_every = 1;
  bool host = false;  // --launcher host: the CPU launcher times itself (no device)
  bool sorted = true;
  bool reserve = true;  // FrameBroadPhase::reserve before frame 0 (--no-reserve: a cold first frame)
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::uint32_t boxes_per_cell = hbp::cuda::FrameOptions{}.boxes_per_cell;
  hbp::cuda::CellSweep sweep = hbp::cuda::FrameOptions{}.sweep;
  hbp::cuda::CellShape cell_shape = hbp::cuda::FrameOptions{}.cell_shape;
  hbp::cuda::PairOrder pair_order = hbp::cuda::FrameOptions{}.pair_order;
  hbp::cuda::PairWrite pair_write = hbp::cuda::FrameOptions{}.pair_write;
  double sustain_s = 0;  // --sustain S: device-entry frames back to back for S seconds
  std::string json;
};

[[noreturn]] void usage() {
  std::fprintf(stderr,
               "usage: hbp-gpu-bench [--system frame|axis-sweep|lbvh] [--kind paper|clustered|flat|huge|degenerate]\n"
               "                     [--n N] [--frames F]\n"
               "                     [--check-every K] [--launcher device|host] [--unsorted] [--no-reserve] [--threads T]\n"
               "                     [--boxes-per-cell B] [--cell-shape columns|cubes] [--sweep per-reference|block-per-cell]\n"
               "                     [--sustain SECONDS]\n"
               "                     [--pair-order radix|buckets] [--pair-write offsets|append] [--json FILE]\n");
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage();
      return argv[++i];
    };
    if (k == "--kind") a.kind = value();
    else if (k == "--system") {
      const std::string system = value();
      a.axis_sweep = system == "axis-sweep";
      a.lbvh = system == "lbvh";
    }
    else if (k == "--n") a.n = static_cast<std::uint32_t>(std::stoul(value()));
    else if (k == "--frames") a.frames = static_cast<std::uint32_t>(std::stoul(value()));
    else if (k == "--check-every") a.check_every = static_cast<std::uint32_t>(std::stoul(value()));
    else if (k == "--threads") a.threads = static_cast<unsigned>(std::stoul(value()));
    else if (k == "--launcher") a.host = value() == "host";
    else if (k == "--unsorted") a.sorted = false;
    else if (k == "--no-reserve") a.reserve = false;
    else if (k == "--boxes-per-cell") a.boxes_per_cell = static_cast<std::uint32_t>(std::stoul(value()));
    else if (k == "--cell-shape") {
      try {
        a.cell_shape = hbp::cuda::parse_cell_shape(value());
      } catch (const hbp::InvalidInput&) {
        usage();
      }
    }
    else if (k == "--sweep") {
      const std::string sweep = value();
      if (sweep == "per-reference") a.sweep = hbp::cuda::CellSweep::PerReference;
      else if (sweep == "block-per-cell") a.sweep = hbp::cuda::CellSweep::BlockPerCell;
      else usage();
    }
    else if (k == "--pair-order") {
      const std::string order = value();
      if (order == "buckets") a.pair_order = hbp::cuda::PairOrder::Buckets;
      else if (order == "radix") a.pair_order = hbp::cuda::PairOrder::Radix;
      else usage();
    }
    else if (k == "--pair-write") {
      const std::string write = value();
      if (write == "offsets") a.pair_write = hbp::cuda::PairWrite::Offsets;
      else if (write == "append") a.pair_write = hbp::cuda::PairWrite::Append;
      else usage();
    }
    else if (k == "--sustain") a.sustain_s = std::stod(value());
    else if (k == "--json") a.json = value();
    else usage();
  }
  if (a.frames == 0 || a.threads == 0 || a.check_every == 0) usage();
  if (a.sustain_s > 0 && (a.host || a.axis_sweep || a.lbvh)) usage();
  if (a.axis_sweep || a.lbvh) a.sorted = true;  // checked against the frame's sorted list
  return a;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  return v[i];
}

// Every pair holding one of `sample` (sorted ids), by brute force against
// all objects; then the same pairs taken from `pairs`. Returns whether equal.
bool sample_check(const hbp::BoxArray& b, const std::vector<hbp::Pair>& pairs, const std::vector<std::uint32_t>& sample,
                  unsigned threads) {
  const auto n = static_cast<std::uint32_t>(b.size());
  std::vector<std::vector<hbp::Pair>> found(sample.size());
  std::vector<std::thread> pool;
  for (unsigned w = 0; w < threads; ++w)
    pool.emplace_back([&, w] {
      for (std::size_t s = w; s < sample.size(); s += threads) {
        const std::uint32_t i = sample[s];
        for (std::uint32_t j = 0; j < n; ++j) {
          if (j == i) continue;
          bool hit = true;
          for (int k = 0; k < 3; ++k) hit = hit && b.max(k)[i] >= b.min(k)[j] && b.min(k)[i] <= b.max(k)[j];
          if (hit) found[s].push_back(i < j ? hbp::Pair{i, j} : hbp::Pair{j, i});
        }
      }
    });
  for (auto& t : pool) t.join();
  std::vector<hbp::Pair> expected, got;
  for (auto& f : found) expected.insert(expected.end(), f.begin(), f.end());
  std::sort(expected.begin(), expected.end());
  expected.erase(std::unique(expected.begin(), expected.end()), expected.end());
  for (const hbp::Pair& p : pairs)
    if (std::binary_search(sample.begin(), sample.end(), p.a) || std::binary_search(sample.begin(), sample.end(), p.b))
      got.push_back(p);
  std::sort(got.begin(), got.end());
  return got == expected;
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw hbp::Error(std::string(what) + ": " + cudaGetErrorString(e));
}

double unix_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

struct Sustained {
  std::uint64_t frames = 0;
  double wall_ms_per_frame = 0;  // host wall clock over the loop / frames
  double start_unix = 0, end_unix = 0;
  bool same_pairs = true;        // every loop frame found the checked frame's count
};

// The frame over `boxes` kept in device memory, through update_device,
// back to back for `seconds`.
Sustained sustain(hbp::cuda::FrameBroadPhase& frame, const hbp::BoxArray& boxes, std::uint64_t pairs,
                  double seconds) {
  const std::size_t n = boxes.size();
  float* device = nullptr;
  check(cudaMalloc(&device, 6 * n * sizeof(float) + 4), "cudaMalloc");
  hbp::cuda::Lanes lanes;
  lanes.n = static_cast<std::uint32_t>(n);
  for (int k = 0; k < 3; ++k) {
    check(cudaMemcpy(device + k * n, boxes.min(k), n * sizeof(float), cudaMemcpyHostToDevice), "upload");
    check(cudaMemcpy(device + (3 + k) * n, boxes.max(k), n * sizeof(float), cudaMemcpyHostToDevice), "upload");
    lanes.lo[k] = device + k * n;
    lanes.hi[k] = device + (3 + k) * n;
  }
  Sustained s;
  frame.update_device(lanes);  // warm: same boxes, buffers already sized
  s.start_unix = unix_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  double elapsed = 0;
  while (elapsed < seconds) {
    const hbp::cuda::DevicePairs got = frame.update_device(lanes);
    s.same_pairs = s.same_pairs && got.count == pairs;
    ++s.frames;
    elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  s.end_unix = unix_seconds();
  s.wall_ms_per_frame = elapsed * 1000 / static_cast<double>(s.frames);
  check(cudaFree(device), "cudaFree");
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  try {
    hbp::ScenarioParams params;
    params.kind = hbp::parse_scenario_kind(args.kind);
    params.n = args.n;
    hbp::Scenario scenario(params);
    hbp::BoxArray boxes;

    hbp::cuda::FrameOptions o;
    o.sorted = args.sorted;
    o.boxes_per_cell = args.boxes_per_cell;
    o.sweep = args.sweep;
    o.cell_shape = args.cell_shape;
    o.pair_order = args.pair_order;
    o.pair_write = args.pair_write;
    o.threads = args.threads;
    o.launcher = args.host ? hbp::cuda::Launcher::Host : hbp::cuda::Launcher::Device;
    hbp::cuda::FrameBroadPhase frame(o);
    hbp::cuda::AxisSweep peer(args.axis_sweep ? o : hbp::cuda::FrameOptions{});
    hbp::cuda::Lbvh lbvh(args.lbvh ? o : hbp::cuda::FrameOptions{});
    hbp::cuda::FrameOptions ro = o;
    ro.launcher = hbp::cuda::Launcher::Host;
    hbp::cuda::FrameBroadPhase reference(ro);
    const bool reserved = args.reserve && !args.axis_sweep && !args.lbvh;
    double reserve_ms = 0;
    if (reserved) {
      const auto t0 = std::chrono::steady_clock::now();
      frame.reserve(args.n);
      reserve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }

    std::vector<double> frame_ms, upload_ms, download_ms, reference_ms, stage[7];
    std::vector<std::uint64_t> pairs_per_frame;
    std::uint64_t steady_allocations = 0, buffer_bytes = 0;
    std::uint32_t mismatches = 0, checked = 0, sample_checks = 0, sample_failures = 0;
    hbp::cuda::FrameInfo last{};
    for (std::uint32_t f = 0; f < args.frames; ++f) {
      scenario.compute_boxes(boxes);
      const std::vector<hbp::Pair>& got = args.axis_sweep ? peer.update(hbp::cuda::lanes_of(boxes))
                                          : args.lbvh     ? lbvh.update(hbp::cuda::lanes_of(boxes))
                                                          : frame.update(hbp::cuda::lanes_of(boxes));
      const hbp::cuda::FrameInfo& info = args.axis_sweep ? peer.info() : args.lbvh ? lbvh.info() : frame.info();
      last = info;
      frame_ms.push_back(info.times.frame_ms);
      upload_ms.push_back(info.times.upload_ms);
      download_ms.push_back(info.times.download_ms);
      const double st[7] = {info.times.bounds_ms, info.times.refs_ms, info.times.sort_ms, info.times.count_ms,
                            info.times.fill_ms, info.times.order_ms, 0};
      for (int s = 0; s < 6; ++s) stage[s].push_back(st[s]);
      pairs_per_frame.push_back(info.pairs);
      if (f > 0) steady_allocations += info.allocations;
      buffer_bytes = std::max<std::uint64_t>(buffer_bytes, info.buffer_bytes);
      if ((f + 1) % args.check_every == 0 || f + 1 == args.frames) {
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<hbp::Pair>& want = reference.update(hbp::cuda::lanes_of(boxes));
        reference_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        ++checked;
        if (want != got) ++mismatches;
      }
      if (f == 0 || f + 1 == args.frames) {
        std::vector<std::uint32_t> sample;
        const std::uint32_t step = std::max<std::uint32_t>(1, args.n / 256);
        for (std::uint32_t i = f % step; i < args.n; i += step) sample.push_back(i);
        ++sample_checks;
        if (!sample_check(boxes, got, sample, args.threads)) ++sample_failures;
      }
      std::fprintf(stderr, "frame %u: %.3f ms device, %llu pairs\n", f, info.times.frame_ms,
                   static_cast<unsigned long long>(info.pairs));
      scenario.step();
    }

    Sustained sustained;
    if (args.sustain_s > 0) sustained = sustain(frame, boxes, pairs_per_frame.back(), args.sustain_s);

    std::vector<double> steady(frame_ms.begin() + (frame_ms.size() > 1 ? 1 : 0), frame_ms.end());
    const double median = percentile(steady, 0.5);
    double mean_pairs = 0;
    for (auto p : pairs_per_frame) mean_pairs += static_cast<double>(p);
    mean_pairs /= static_cast<double>(pairs_per_frame.size());
    const bool exact = mismatches == 0 && sample_failures == 0 && sustained.same_pairs;

    std::string j = "{\n";
    auto num = [&](const char* key, double v, bool comma = true) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "  \"%s\": %.6g%s\n", key, v, comma ? "," : "");
      j += buf;
    };
    auto str = [&](const char* key, const std::string& v) { j += "  \"" + std::string(key) + "\": \"" + v + "\",\n"; };
    str("system", args.axis_sweep ? "axis-sweep" : args.lbvh ? "lbvh" : "frame");
    str("launcher", args.host ? "host" : "device");
    str("device", args.host ? "" : hbp::cuda::device_name());
    str("kind", args.kind);
    str("order", args.sorted ? "sorted by (a, b)" : "frame order");
    str("cell_shape", hbp::cuda::cell_shape_name(args.cell_shape));
    str("sweep", args.sweep == hbp::cuda::CellSweep::PerReference ? "per-reference" : "block-per-cell");
    str("pair_order", args.pair_order == hbp::cuda::PairOrder::Buckets ? "buckets" : "radix");
    str("pair_write", args.pair_write == hbp::cuda::PairWrite::Append ? "append" : "offsets");
    num("objects", args.n);
    num("frames", args.frames);
    num("host_threads", args.threads);
    str("first_frame", reserved ? "after reserve" : "cold");
    num("reserve_ms", reserve_ms);
    num("first_frame_ms", frame_ms.front());
    num("median_frame_ms", median);
    num("p99_frame_ms", percentile(steady, 0.99));
    num("worst_frame_ms", *std::max_element(steady.begin(), steady.end()));
    num("median_upload_ms", percentile(upload_ms, 0.5));
    num("median_download_ms", percentile(download_ms, 0.5));
    const char* names[6] = {"bounds", "refs", "sort", "count", "fill", "order"};
    for (int s = 0; s < 6; ++s) num((std::string("median_") + names[s] + "_ms").c_str(), percentile(stage[s], 0.5));
    num("mean_pairs", mean_pairs);
    num("pairs_per_second", median > 0 ? mean_pairs / (median / 1000) : 0);
    num("cells", last.cells);
    num("references", last.references);
    num("large", last.large);
    num("grid_x", last.grid[0]);
    num("grid_y", last.grid[1]);
    num("grid_z", last.grid[2]);
    num("buffer_bytes", static_cast<double>(buffer_bytes));
    num("steady_allocations", static_cast<double>(steady_allocations));
    num("reference_median_ms", percentile(reference_ms, 0.5));
    num("frames_checked", checked);
    num("frames_mismatched", mismatches);
    num("sample_checks", sample_checks);
    num("sample_failures", sample_failures);
    if (args.sustain_s > 0) {
      num("sustained_frames", static_cast<double>(sustained.frames));
      num("sustained_wall_ms_per_frame", sustained.wall_ms_per_frame);
      char buf[96];
      std::snprintf(buf, sizeof buf, "  \"sustained_start_unix\": %.3f,\n  \"sustained_end_unix\": %.3f,\n",
                    sustained.start_unix, sustained.end_unix);
      j += buf;
    }
    j += "  \"pairs_per_frame\": [";
    for (std::size_t f = 0; f < pairs_per_frame.size(); ++f)
      j += (f ? ", " : "") + std::to_string(pairs_per_frame[f]);
    j += "],\n";
    j += std::string("  \"exact\": ") + (exact ? "true" : "false") + "\n}\n";
    if (!args.json.empty()) {
      FILE* out = std::fopen(args.json.c_str(), "w");
      if (!out) throw hbp::Error("cannot write " + args.json);
      std::fputs(j.c_str(), out);
      std::fclose(out);
    }
    std::fputs(j.c_str(), stdout);
    return exact ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hbp-gpu-bench: error: %s\n", e.what());
    return 1;
  }
}
