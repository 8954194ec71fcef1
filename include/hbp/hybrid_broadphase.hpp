// SPDX-License-Identifier: MIT
#pragma once
// The hybrid system: k-d spatial partition -> cell engine -> de-duplication,
// one frame at a time, keeping the partition across frames.
//
//   hbp::HybridBroadPhase bp({.engine = "sw", .threads = 2});
//   bp.update(boxes);                       // a frame of hbp::BoxArray
//   for (hbp::Pair p : bp.pairs()) ...      // canonical, each pair once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_engine.hpp"
#include "hbp/pair.hpp"
#include "hbp/task_system.hpp"
#include "hbp/validated_boxes.hpp"

namespace hbp {

class KdPartition;

// The hybrid system's options. Every consumer honours each field except
// two: `sorted` is HybridBroadPhase's alone (BroadPhase, the Bullet adapter
// and DistributedBroadPhase always sort, CollisionPipeline keeps cell order:
// its narrow phase takes the cells as they come), and `double_precision`
// is BroadPhase's alone (the others refuse it).
struct BroadPhaseOptions {
  std::string engine = "sw";     // see make_cell_engine()
  std::uint32_t cell_limit = 0;  // 0: the engine's default; else >= 2
  unsigned threads = 0;          // 0: all cores; at most kMaxThreads (hbp/limits.hpp), else InvalidInput
  bool sorted = true;            // pairs sorted by (a, b); else cell order
  std::uint64_t max_pairs = 0;   // 0: unlimited; else CapacityExceeded beyond
  // Hardware engines: keep splitting cells under the limit while that lowers
  // the summed modelled cycles (the paper splits only down to the limit).
  bool cost_splits = false;
  // Double-precision boxes (AabbD) with a float32 filter and exact double
  // confirmation: honoured by BroadPhase alone (hbp/broad_phase.hpp);
  // HybridBroadPhase and every other consumer reject it (InvalidInput).
  bool double_precision = false;
  // The engine's job system (hbp/task_system.hpp), which then runs every
  // parallel loop of a call in place of the library's own oneTBB arena
  // (`threads` is unused but still checked). Null: that arena. Not owned:
  // it must outlive the broad phase. The output is the same either way.
  TaskSystem* task_system = nullptr;
};

struct FrameStats {
  std::uint64_t pairs = 0;
  // Pairs the engine calls returned, summed over calls. Each call already
  // applies the ownership test (find_owned_pairs), so this equals `pairs`
  // except in over-full cells processed in tiles, where a block's own pairs
  // come back from several calls and all but one copy are dropped.
  std::uint64_t candidate_pairs = 0;
  std::uint32_t cells = 0;
  std::uint32_t min_cell = 0, median_cell = 0, max_cell = 0;
  double duplication = 1.0;  // cell entries / objects
  std::uint32_t oversized_cells = 0;  // could not be split: processed in tiles
  bool rebuilt = false;               // partition rebuilt from scratch this frame
  // A rebuild on quality loss is spread over frames: the subtrees rebuilt
  // from their own members this frame, and their entries.
  std::uint32_t rebuilt_subtrees = 0;
  std::uint64_t rebuilt_entries = 0;
  std::uint32_t splits = 0, merges = 0;  // incremental partition maintenance
  // Measured wall times (steady clock) of the frame's stages, which add up
  // to wall_ms:
  //   partition_ms  validation, tree maintenance, routing (0 on a shared
  //                 partition and on one-cell frames, see below)
  //   engine_ms     every cell through the engine, de-duplication included:
  //                 the ownership test (src/dedup/) runs on each candidate
  //                 as the engine finds it, so it has no time of its own
  //   merge_ms      writing the frame's pair list from the cells (copies;
  //                 pair-dense cells re-run their kernel straight into it)
  //   sort_ms       sorting it by (a, b) (0 when options().sorted is false)
  double wall_ms = 0, partition_ms = 0, engine_ms = 0, merge_ms = 0, sort_ms = 0;
  // The stages after the engines, merge_ms + sort_ms: what `hbp run --json`
  // prints as "dedup_ms" (the paper's name for the stage after the cell
  // engine; the key is read by outside programs). It does not contain the
  // de-duplication itself, which is in engine_ms (above).
  double after_engines_ms() const { return merge_ms + sort_ms; }
  // Frames of at most cell_limit objects skip the partition: one cell, run
  // on the calling thread (the partition would make exactly that cell).
  bool one_cell = false;
  std::uint64_t modelled_cycles = 0;  // sum over cells (one accelerator)
  double modelled_ms = 0;             // modelled_cycles / clock (0 if software)
};

// Called with each cell's de-duplicated pairs (global ids, canonical). The
// ordered sink sees cells in cell order, one call at a time, while later
// cells are still in the engine; the parallel consumer runs on any worker
// thread, several cells at once, right after the cell's engine run (the
// narrow phase hook: consume in parallel, publish in order).
using PairSink = std::function<void(std::uint32_t cell, const Pair* pairs, std::size_t count)>;

class HybridBroadPhase {
 public:
  explicit HybridBroadPhase(const BroadPhaseOptions& options = {});
  ~HybridBroadPhase();
  HybridBroadPhase(HybridBroadPhase&&) noexcept;
  HybridBroadPhase& operator=(HybridBroadPhase&&) noexcept;

  // Runs one frame. Boxes are validated (InvalidInput names the object).
  // CapacityExceeded when the frame has more than options().max_pairs pairs
  // (checked as cells complete, so memory stays bounded).
  const std::vector<Pair>& update(const BoxArray& boxes, const PairSink& sink = {},
                                  const PairSink& parallel_consumer = {});
  // The same on boxes already screened (BroadPhase keeps its moving boxes
  // screened as they are written): no screen of its own.
  const std::vector<Pair>& update(const ValidatedBoxes& boxes, const PairSink& sink = {},
                                  const PairSink& parallel_consumer = {});
  // Runs the engines on cells partitioned elsewhere (the ray tracer's shared
  // two-level hierarchy, see two_level_hierarchy.hpp), so a frame maintains
  // one structure, not two. partition_ms is then 0.
  const std::vector<Pair>& update(const KdPartition& cells, const PairSink& sink = {},
                                  const PairSink& parallel_consumer = {});
  // Provisions the memory that frames of up to `objects` objects keep from
  // frame to frame (the partition's cell buffers and per-object records,
  // ~170 bytes an object) and faults its pages in on every worker, so that
  // a first frame of that size finds it resident: the cost of fresh memory
  // moves to the call (an engine's level load). Optional; the pairs are the
  // same either way. Frames much smaller than `objects` give the memory
  // back, as any frame does. CapacityExceeded from 2^32 - 1 objects on;
  // std::bad_alloc when the memory cannot be had (nothing else changes).
  void reserve(std::size_t objects);
  const std::vector<Pair>& pairs() const;
  // Exchanges the last frame's pairs with `other` (any contents) without a
  // copy; the next frame writes into the storage it gets back.
  void swap_pairs(std::vector<Pair>& other);
  const FrameStats& stats() const;
  const BroadPhaseOptions& options() const;
  std::uint32_t cell_limit() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp
