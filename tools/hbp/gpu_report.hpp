// SPDX-License-Identifier: MIT
#pragma once
// The stored report of a GPU machine's run (scripts/gpu-check writes it;
// docs/results/gpu/gpu-report.json is the one kept in the tree): the GPU,
// the date, the paper scene's frame at 1,024,000 objects (device time, with
// transfers, the peers and our CPU engine on that machine, energy), and the
// GPU frame's median per object count of the paper scene. `hbp hw energy`
// and `hbp bench paper` read it, labelled with its GPU and date: a GPU
// figure comes only from a GPU run.
#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace hbp::cli {

inline constexpr const char* kGpuReportPath = "docs/results/gpu/gpu-report.json";

struct GpuPaperFrame {
  double frame_ms = 0;            // median device time, bounds .. order
  double with_transfers_ms = 0;   // plus the median upload and download
  double energy_per_frame_j = 0;  // 0: not measured
  double axis_sweep_ms = 0;       // the one-axis sort-and-sweep peer, same run (0: absent)
  double lbvh_ms = 0;             // the LBVH peer, same run (0: absent)
  double cpu_sw_ms = 0;           // our CPU engine on that machine's cores, same run (0: absent)
  double cells_accelerator_ms = 0;  // the paper's split: our CPU's cells on the GPU ("cuda" engine time; 0: absent)
};

struct GpuReport {
  std::string gpu;   // as nvidia-smi names it
  std::string date;  // ISO 8601, UTC
  std::string host;  // the machine's CPUs
  GpuPaperFrame paper;
  std::map<std::uint32_t, double> paper_frame_ms;  // objects -> median device ms (sorted pairs)
};

// The report at `path`, or nothing when it is missing, not a device run, or
// lacks the paper frame (anything else reads as not measured).
std::optional<GpuReport> read_gpu_report(const std::string& path);

}  // namespace hbp::cli
