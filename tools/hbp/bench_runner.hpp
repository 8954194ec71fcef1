// SPDX-License-Identifier: MIT
#pragma once
// Runs every bench system on the same frames, row by row (one row per object
// count), checks each system's exact pair set against the reference (our
// software hybrid) every frame, and skips systems whose projected time for a
// row exceeds the budget.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bench_systems.hpp"
#include "hbp/box_array.hpp"

namespace hbp::cli {

// Frames of one world: variant v starts with frame 0 (setup, untimed), then
// next() yields the following frames. The same boxes go to every system.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual std::uint32_t object_count() const = 0;
  virtual void begin_variant(std::uint32_t variant, BoxArray& first) = 0;
  virtual void next(BoxArray& boxes) = 0;
};

struct BenchConfig {
  std::uint32_t frames = 10;   // timed frames per variant
  std::uint32_t variants = 3;  // worlds per row (paper scenario: seed = variant)
  std::uint32_t warmup = 3;    // untimed frames after setup, per variant
  double budget_s = 120;       // per system per row: skip when projected beyond
  // Per-system budgets overriding budget_s (key -> seconds), e.g. a small one
  // for bt32BitAxisSweep3, whose quadratic setup would eat a large budget.
  std::vector<std::pair<std::string, double>> budget_for;
  double budget_of(const std::string& key) const {
    for (const auto& [k, s] : budget_for)
      if (k == key) return s;
    return budget_s;
  }
  std::vector<std::string> only;  // system keys to run (empty: all)
  SystemChoice choice;
};

// Projected: over budget at this size, so not run; its time is projected
// from its measured rows (never shown as measured).
enum class CellStatus { Ran, Skipped, NotApplicable, Failed, Projected };

struct CellResult {
  CellStatus status = CellStatus::NotApplicable;
  double median_ms = 0, min_ms = 0, max_ms = 0;  // reported (measured or modelled); max = worst frame
  double p99_ms = 0;                             // 99th percentile (nearest rank) of the timed frames
  double median_wall_ms = 0;                     // this machine's cost
  double median_cpu_ms = 0;                      // calling thread's CPU time
  double setup_s = 0;                            // mean one-time setup per variant (the first frame:
                                                 // proxies created / structures built), wall time
  double pairs_per_s = 0;                        // reference's exact pairs / median frame time
  std::uint64_t peak_bytes = 0;                  // peak memory attributed to the system (bench_memory.hpp)
  bool memory_measured = false;
  double projected_ms = 0, projected_setup_s = 0;  // Projected: from the measured scaling
  std::uint32_t frames = 0;                      // timed frames recorded
  std::uint32_t mismatched_frames = 0;
  std::uint64_t median_raw_pairs = 0;
  std::string note;  // "skipped, projected 31 min", "n > capacity 1024", error text
};

struct Sample {
  std::uint32_t n, variant, frame;
  std::uint32_t system;  // index into BenchResult::keys
  double reported_ms, wall_ms, cpu_ms;
  std::uint64_t raw_pairs, exact_pairs;
  bool match;
};

struct Mismatch {
  std::uint32_t n, variant, frame;
  std::string system, reference, summary;
};

struct RowResult {
  std::uint32_t n = 0;
  std::uint64_t median_pairs = 0;  // reference's exact pairs
  std::vector<CellResult> cells;   // per system, in BenchResult::keys order
};

struct BenchResult {
  std::vector<std::string> keys, labels;
  std::vector<bool> modelled;
  std::vector<std::string> missing;  // systems not built into this binary
  std::string reference = "sw";
  std::vector<RowResult> rows;
  std::vector<Sample> samples;
  std::vector<Mismatch> mismatches;
  double total_s = 0;
};

class BenchRunner {
 public:
  // progress(done, total, what): work is counted in object-frames.
  using Progress = std::function<void(double done, double total, const std::string& what)>;
  // Messages (mismatches, failures) printed as they happen.
  using Log = std::function<void(const std::string& line)>;

  BenchRunner(const BenchConfig& config, Progress progress, Log log);
  ~BenchRunner();

  // Total work of the rows to come, for the progress bar's ETA.
  void plan(const std::vector<std::uint32_t>& object_counts);
  void run_row(FrameSource& source);
  BenchResult& result() { return result_; }

 private:
  struct History {
    std::uint32_t n;
    double frame_wall_ms;      // median per timed frame
    double frame_reported_ms;  // the same on the reported clock
    double setup_s;            // mean per variant
  };
  struct Projection {
    double frame_wall_ms = 0, frame_reported_ms = 0, setup_s = 0;
    double row_seconds = 0;  // what the row would cost (variants x (setup + frames))
  };
  Projection project(std::size_t system, std::uint32_t n) const;

  BenchConfig config_;
  Progress progress_;
  Log log_;
  std::vector<std::unique_ptr<BenchSystem>> systems_;
  std::vector<std::vector<History>> history_;
  BenchResult result_;
  double work_total_ = 0, work_done_ = 0;
};

}  // namespace hbp::cli
