// SPDX-License-Identifier: MIT
#pragma once
// The systems `hbp bench` compares, behind one interface: the baselines
// (Bullet, CGAL, brute force; measured), our software hybrid (measured) and
// the two microarchitectures (modelled: cycles at the model's clock), either
// over the whole world ("none": no partition, one accelerator load) or behind
// the k-d partition with a given cell size.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"
#include "hbp/shape.hpp"

namespace hbp::cli {

struct FrameTime {
  double reported_ms = 0;  // what the table shows: measured (wall or CPU) time, or modelled time
  double wall_ms = 0;      // what the frame cost this machine (for budgets and ETA)
  double cpu_ms = 0;       // CPU time of the calling thread during the frame
};

class BenchSystem {
 public:
  virtual ~BenchSystem() = default;
  // Stable key for files ("bullet-dbvt", "sw", "ae-none", "mo-2048").
  virtual std::string key() const = 0;
  // Column label ("Bullet DBVT", "AE 1024").
  virtual std::string label() const = 0;
  virtual bool modelled() const = 0;
  // Whether the system takes part for n objects (the paper's blank cells:
  // no "none" beyond the accelerator's capacity, no cell size >= n).
  virtual bool applies(std::uint32_t n) const = 0;
  // Why it does not apply ("n > capacity 1024").
  virtual std::string not_applicable_reason(std::uint32_t n) const = 0;
  // Untimed one-time preparation with the first frame.
  virtual void setup(const BoxArray& boxes) = 0;
  virtual FrameTime update(const BoxArray& boxes) = 0;
  virtual std::uint64_t raw_pairs() const = 0;
  // Sorted, canonical pairs of the last frame (untimed).
  virtual const std::vector<Pair>& exact_pairs() = 0;
};

enum class BenchClock {
  Wall,  // steady_clock: what a user waits (the paper's measure)
  Cpu,   // CPU time of the calling thread: robust on a loaded, shared machine;
         // only meaningful when all work runs on that thread (--threads 1)
};

struct SystemChoice {
  unsigned threads = 1;  // our software hybrid (the baselines are single-threaded)
  BenchClock clock = BenchClock::Wall;
  // The frames come with shapes (generated scenes, not box files): adds the
  // full pipeline (broad + narrow phase) as a measured column.
  bool shapes = false;
};

// The shapes of the frame being benchmarked (set by the paper-scene source;
// null for recorded box files).
const std::vector<Shape>*& current_bench_shapes();

// Every system, in table order. Systems whose engine is not built into this
// binary (e.g. the hardware models) are left out and named in `missing`.
std::vector<std::unique_ptr<BenchSystem>> make_bench_systems(const SystemChoice& choice,
                                                             std::vector<std::string>& missing);

// Keys in table order, whether built or not (for --systems help).
std::vector<std::string> bench_system_keys();

}  // namespace hbp::cli
