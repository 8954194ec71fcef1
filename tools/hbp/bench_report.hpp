// SPDX-License-Identifier: MIT
#pragma once
// `hbp bench` output: Table-4-shaped tables (medians in ms, measured and
// modelled columns labelled), acceleration factors against Bullet DBVT, the
// paper's own figures beside ours, and files for every per-frame sample
// (CSV, JSON) plus plot data.
#include <string>
#include <utility>
#include <vector>

#include "bench_machine.hpp"
#include "bench_runner.hpp"
#include "gpu_report.hpp"

namespace hbp::cli {

struct BenchHeader {
  std::string title;    // "paper scenario" / "scene FILE"
  std::string command;  // the command line that produced the run
  std::string scene;    // what the frames are
  bool paper = true;    // compare with the paper's Table 4
  std::string gpu_report = kGpuReportPath;  // the GPU column's stored report (gpu_report.hpp)
  BenchConfig config;
  MachineDescription machine;
  std::string started;  // ISO 8601 local time
};

// The tables as Markdown (tables.md; docs/results.md shows them).
std::string format_tables(const BenchResult& r, const BenchHeader& h);

// What `hbp bench` prints when it is done (the full tables are in the
// report's tables.md): per object count the pairs, the fastest measured
// system and the reference's and Bullet DBVT's medians, then whether every
// system matched the reference.
std::string format_summary(const BenchResult& r);

// Writes tables.md, summary.csv, samples.csv, report.json, times.dat and
// accel.dat into dir (created if needed). Returns the files written.
std::vector<std::string> write_report_files(const std::string& dir, const BenchResult& r, const BenchHeader& h);

}  // namespace hbp::cli
