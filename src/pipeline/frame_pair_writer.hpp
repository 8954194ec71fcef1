// SPDX-License-Identifier: MIT
#pragma once
// The one pair writer of a partitioned frame: cell c's pairs land at
// offsets[c] of the frame's list, the sum of the pairs of the cells before
// it, so the list is the same, in the same order, for any thread count.
//
// A steady frame writes its cells in place (the lanes of cell_lanes.hpp, in
// the last frame's list); a cell that finds no room falls back to its
// worker's store, copied to its place at the merge; a cell too dense to
// store (a frame with no estimate of its pair count) is counted, then
// written by a second kernel run. Streamed frames (a sink or a parallel
// consumer) keep a list per cell and gather them at the merge.
#include <tbb/enumerable_thread_specific.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "hbp/hybrid_broadphase.hpp"
#include "hbp/kd_partition.hpp"
#include "hbp/pair.hpp"
#include "partition/raw_buffer.hpp"
#include "pipeline/cell_worker.hpp"
#include "pipeline/pair_outputs.hpp"

namespace hbp::detail {

using Workers = tbb::enumerable_thread_specific<Worker>;

// This frame's cells as the writer reads them. `refreshing`, when set, is
// the partition whose cells are rewritten on their first trip through the
// engine (kept members with this frame's boxes, plus newcomers), so the
// engine reads each from the cache instead of after a pass over all cells.
struct FrameCells {
  const KdPartition* partition = nullptr;
  KdPartition* refreshing = nullptr;
  // `lanes` workers run the engine stage; 1: the calling thread alone.
  int lanes = 1;

  std::uint32_t count() const { return partition->cell_count(); }
  const CellRegion& region(std::uint32_t c) const { return partition->region(c); }
  std::span<const CellEntry> engine_cell(std::uint32_t c) const {
    return refreshing ? refreshing->refresh_cell(c) : partition->cell(c);
  }
};

class FramePairWriter {
 public:
  // direct_kernel: the workers' engines have the streaming door
  // (CellHitStream) whose count and emit calls the writer drives itself;
  // other engines take whole cells (cell_pairs.hpp). max_pairs: 0 or the
  // frame's pair limit (CapacityExceeded beyond).
  FramePairWriter(Workers& workers, bool direct_kernel, std::uint64_t max_pairs);

  // Measured wall times of the engine stage and of the merge after it.
  struct StageTimes {
    double engine_ms = 0, merge_ms = 0;
  };

  // A frame of one cell, already loaded into `w` (no partition, no workers).
  void write_one_cell(Worker& w, const PairSink& sink, const PairSink& consumer);
  // Every cell through the engine, then the merge into one list.
  StageTimes write_cells(const FrameCells& cells);
  // Every cell into its own list, handed to the consumer (any worker, right
  // after the engine) and the sink (in cell order, while later cells are
  // still in the engine); the lists gathered into one at the merge.
  StageTimes stream_cells(const FrameCells& cells, const PairSink& sink, const PairSink& consumer);
  // After the frame (sorted or not): per-worker buffers follow its needs,
  // and its pair count sizes the next frame's stores when `estimate`.
  void end_frame(bool estimate);

  std::vector<Pair>& pairs() { return pairs_; }
  const std::vector<Pair>& pairs() const { return pairs_; }
  const std::vector<CellOutcome>& outcomes() const { return outcomes_; }

 private:
  void begin_cells(const FrameCells& cells);
  void charge(std::size_t pairs_added);
  auto charger() {
    return [this](std::size_t n) { charge(n); };
  }
  template <class F>
  void for_each_cell(F&& f);

  // The stores.
  void store_batches();
  void store_batch(std::uint32_t first, std::uint32_t end);
  void first_pass(std::uint32_t c, bool loaded = false);
  bool store_within_budget(Worker& w, const CellRegion& region, CellOutcome& r);
  void second_pass(std::uint32_t c);
  std::size_t store_share() const;
  void size_stores();
  // In place.
  bool front_lane_allowed() const;
  void run_lanes();
  bool front_cell(std::uint32_t c, ListFront& front);
  bool back_cell(std::uint32_t c, ListBack& back);
  // The frame's list.
  void size_output();
  void move_pairs(std::size_t from, std::size_t to, std::size_t count);
  void reserve_output(std::size_t total);

  Workers& workers_;
  const bool direct_kernel_;
  const std::uint64_t max_pairs_;
  FrameCells cells_;                          // this frame's
  std::vector<CellOutcome> outcomes_;         // per cell
  std::vector<std::vector<Pair>> cell_pairs_;  // per cell, when a sink or consumer streams them
  std::vector<std::size_t> offsets_;          // per cell: first pair in pairs_
  std::vector<std::uint32_t> batch_starts_;   // the frame's batches of cells (engines without the streaming door)
  std::vector<Pair> pairs_;                   // the frame's list
  RawBuffer<Pair> move_scratch_;              // pairs set aside while the back lane's block moves
  std::atomic<std::uint64_t> running_pairs_{0};
  std::size_t last_frame_pairs_ = 0;  // the pair count of the last frame with an estimate
  bool count_dense_cells_ = false;    // this frame has no estimate: dense cells are counted, then written
  std::size_t in_place_pairs_ = 0;    // pairs the front lane wrote straight into pairs_ this frame
  std::size_t back_pairs_ = 0;        // pairs the back lane wrote into pairs_, ending at back_window_
  std::size_t back_window_ = 0;       // the list's length while the lanes ran
};

}  // namespace hbp::detail
