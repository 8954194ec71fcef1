// SPDX-License-Identifier: MIT
// The hybrid system's frame, top to bottom (run):
//   1. partition: the k-d tree maintained over this frame's boxes (or cells
//      partitioned elsewhere, or none at all for a one-cell frame);
//   2. engine over the cells: each cell loaded in min-x order and run
//      through its worker's engine (cell_pairs.hpp), in parallel;
//   3. one pair writer (frame_pair_writer.hpp): cell c's pairs land at the
//      sum of the pairs of the cells before it, so the list is the same, in
//      the same order, for any thread count;
//   4. the list sorted by (a, b) when options().sorted.
#include "hbp/hybrid_broadphase.hpp"


#include <algorithm>
#include <cstdint>
#include <limits>

#include "hbp/error.hpp"
#include "hbp/kd_partition.hpp"
#include "pipeline/cell_worker.hpp"
#include "pipeline/frame_pair_writer.hpp"
#include "pipeline/frame_stats.hpp"
#include "pipeline/frame_threads.hpp"
#include "pipeline/parallel_pair_sort.hpp"
#include "pipeline/screened_boxes.hpp"
#include "support/clock.hpp"
#include "support/retained.hpp"

namespace hbp {

using detail::FrameCells;
using detail::Worker;

namespace {

// Frames whose cells hold fewer entries than this run the engine phase on the
// calling thread: below it, handing cells to workers costs more than the
// cells themselves.
constexpr std::uint64_t kSerialEntries = 16384;

}  // namespace

struct HybridBroadPhase::Impl {
  BroadPhaseOptions options;
  std::unique_ptr<CellEngine> prototype;
  std::uint32_t cell_limit;
  detail::FrameThreads arena;  // the engine's task system, or an own oneTBB arena
  KdPartition own_partition;
  bool partition_in_use = false;                  // own_partition holds a tree from an earlier frame
  bool refresh_in_engine = false;                 // own_partition's cells are refreshed as the engine takes them
  const KdPartition* partition = &own_partition;  // this frame's cells
  detail::Workers workers;
  detail::FramePairWriter writer;
  std::vector<Pair> sort_scratch;
  FrameStats stats;

  static std::uint32_t choose_limit(const BroadPhaseOptions& o, const CellEngine& e) {
    const std::uint32_t limit = o.cell_limit ? o.cell_limit : e.default_cell_limit();
    if (limit < 2) throw InvalidInput("cell limit must be >= 2 (got " + std::to_string(limit) + ")");
    return limit;
  }

  static KdPartition::CellCost cell_cost(const BroadPhaseOptions& o, const CellEngine& e) {
    if (!o.cost_splits || e.clock_hz() <= 0) return {};
    // The cells of a frame run one after another: their cycles add up.
    std::shared_ptr<const CellEngine> engine = e.clone();
    return [engine](std::uint32_t n) { return static_cast<double>(engine->cycles_for(n)); };
  }

  // double_precision is BroadPhase's alone (it runs this system on float
  // boxes); every other consumer builds one of these and so rejects it.
  static const BroadPhaseOptions& float_only(const BroadPhaseOptions& o) {
    if (o.double_precision)
      throw InvalidInput("double_precision is honoured by hbp::BroadPhase only (HybridBroadPhase takes float boxes)");
    return o;
  }

  explicit Impl(const BroadPhaseOptions& o)
      : options(float_only(o)),
        prototype(make_cell_engine(o.engine)),
        cell_limit(choose_limit(o, *prototype)),
        arena(o.threads, o.task_system),
        own_partition(cell_limit, prototype->x_split_weight(), cell_cost(o, *prototype)),
        workers([this] {
          Worker w;
          w.engine = prototype->clone();
          if (options.max_pairs) w.engine->set_pair_limit(options.max_pairs);
          w.direct = w.engine->hit_stream();
          return w;
        }),
        writer(workers, prototype->hit_stream() != nullptr, o.max_pairs) {}

  // ---- The frame -----------------------------------------------------------

  // A frame of boxes. Small frames stay on the calling thread: entering the
  // arena would wake its workers for nothing.
  void run_boxes(const BoxArray& boxes, bool checked, const PairSink& sink, const PairSink& consumer) {
    if (boxes.size() <= cell_limit)
      arena.execute_here([&] { run(&boxes, nullptr, checked, sink, consumer); });
    else
      arena.execute([&] { run(&boxes, nullptr, checked, sink, consumer); });
  }

  // checked: the boxes were screened by the caller (ValidatedBoxes).
  void run(const BoxArray* boxes, const KdPartition* shared, bool checked, const PairSink& sink,
           const PairSink& consumer) {
    const auto t0 = SteadyClock::now();
    double partition_ms = 0;
    detail::FramePairWriter::StageTimes times;
    const bool one_cell = !shared && is_one_cell_frame(boxes);
    if (one_cell) {
      const auto t_engine = SteadyClock::now();
      run_one_cell(*boxes, checked, sink, consumer);
      times.engine_ms = ms_since(t_engine);
    } else {
      const auto t_partition = SteadyClock::now();
      partition_frame(boxes, shared, checked);
      partition_ms = ms_since(t_partition);
      times = run_cells_and_finish(sink, consumer, partition_ms);
    }
    const auto t_sort = SteadyClock::now();
    sort_output();
    const double sort_ms = ms_since(t_sort);
    writer.end_frame(!(one_cell || sink || consumer));
    record_stats(one_cell, boxes ? boxes->size() : 0);
    stats.partition_ms = partition_ms;
    stats.engine_ms = times.engine_ms;
    stats.merge_ms = times.merge_ms;
    stats.sort_ms = sort_ms;
    stats.wall_ms = ms_since(t0);
  }

  // Frames the partition would leave as one cell: no partition, no workers.
  bool is_one_cell_frame(const BoxArray* boxes) const { return boxes && boxes->size() <= cell_limit; }

  void run_one_cell(const BoxArray& boxes, bool checked, const PairSink& sink, const PairSink& consumer) {
    if (!checked) detail::screen_boxes_serial(boxes);
    if (partition_in_use) own_partition.reset();  // its tree is stale by the next large frame
    partition_in_use = false;
    Worker& w = workers.local();
    w.cell.load(boxes);
    if (w.direct) w.direct->owner_codes(w.cell.boxes(), CellRegion::everything(), w.codes);
    writer.write_one_cell(w, sink, consumer);
  }

  void partition_frame(const BoxArray* boxes, const KdPartition* shared, bool checked) {
    if (shared) {
      partition = shared;  // cells maintained elsewhere (the ray tracer's hierarchy)
      return;
    }
    partition = &own_partition;
    if (!checked) detail::screen_boxes(*boxes);
    // An engine without a capacity limit takes a cell a few objects over the
    // cell limit for one frame (split at the start of the next); others get
    // the refresh in the engine only when no cell can outgrow the limit.
    const bool unlimited = prototype->capacity() == std::numeric_limits<std::uint32_t>::max();
    refresh_in_engine = own_partition.begin_update(*boxes, unlimited);
    partition_in_use = true;
  }

  // The engine stage and the pair writer, with the partition's deferred
  // refresh: completed after them, or, when a cell throws (max_pairs), the
  // half-refreshed tree dropped.
  detail::FramePairWriter::StageTimes run_cells_and_finish(const PairSink& sink, const PairSink& consumer,
                                                           double& partition_ms) {
    detail::FramePairWriter::StageTimes times;
    try {
      const FrameCells cells{partition, refresh_in_engine ? &own_partition : nullptr, engine_lanes()};
      times = sink || consumer ? writer.stream_cells(cells, sink, consumer) : writer.write_cells(cells);
    } catch (...) {
      if (refresh_in_engine) {
        refresh_in_engine = false;
        own_partition.reset();
        partition_in_use = false;
      }
      throw;
    }
    if (!refresh_in_engine) return times;
    refresh_in_engine = false;
    const auto t_finish = SteadyClock::now();
    own_partition.finish_update();
    partition_ms += ms_since(t_finish);
    return times;
  }

  // Workers of this frame's engine stage (1: the calling thread alone).
  int engine_lanes() const {
    const bool serial = arena.max_concurrency() == 1 || partition->stats().entries < kSerialEntries;
    return serial ? 1 : std::max(1, arena.max_concurrency());
  }

  void sort_output() {
    std::vector<Pair>& pairs = writer.pairs();
    if (options.sorted) parallel_sort_pairs(pairs, sort_scratch, arena);  // scratch: the list + a small tail
    retained::release(sort_scratch, options.sorted ? pairs.size() : 0, detail::kKeepPairs);
  }

  void record_stats(bool one_cell, std::size_t objects) {
    std::uint64_t cycles = 0, cand = 0;
    for (const detail::CellOutcome& r : writer.outcomes()) {
      cycles += r.cycles;
      cand += r.candidates;
    }
    stats.pairs = writer.pairs().size();
    stats.candidate_pairs = cand;
    stats.modelled_cycles = cycles;
    const double hz = prototype->clock_hz();
    stats.modelled_ms = hz > 0 ? 1e3 * static_cast<double>(cycles) / hz : 0.0;
    stats.one_cell = one_cell;
    if (one_cell)
      detail::set_one_cell_stats(stats, static_cast<std::uint32_t>(objects));
    else
      detail::set_partition_stats(stats, partition->stats());
  }
};
HybridBroadPhase::HybridBroadPhase(const BroadPhaseOptions& options) : impl_(std::make_unique<Impl>(options)) {}
HybridBroadPhase::~HybridBroadPhase() = default;
HybridBroadPhase::HybridBroadPhase(HybridBroadPhase&&) noexcept = default;
HybridBroadPhase& HybridBroadPhase::operator=(HybridBroadPhase&&) noexcept = default;

const std::vector<Pair>& HybridBroadPhase::update(const BoxArray& boxes, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->run_boxes(boxes, false, sink, parallel_consumer);
  return impl_->writer.pairs();
}

const std::vector<Pair>& HybridBroadPhase::update(const ValidatedBoxes& boxes, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->run_boxes(boxes.boxes(), true, sink, parallel_consumer);
  return impl_->writer.pairs();
}

const std::vector<Pair>& HybridBroadPhase::update(const KdPartition& cells, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->arena.execute([&] { impl_->run(nullptr, &cells, false, sink, parallel_consumer); });
  return impl_->writer.pairs();
}
void HybridBroadPhase::reserve(std::size_t objects) {
  // A frame of at most cell_limit objects is one cell, not partitioned (the
  // partition checks the object limit).
  if (objects <= impl_->cell_limit) return;
  impl_->arena.execute([&] { impl_->own_partition.reserve(objects); });
}

const std::vector<Pair>& HybridBroadPhase::pairs() const { return impl_->writer.pairs(); }
const FrameStats& HybridBroadPhase::stats() const { return impl_->stats; }
const BroadPhaseOptions& HybridBroadPhase::options() const { return impl_->options; }
std::uint32_t HybridBroadPhase::cell_limit() const { return impl_->cell_limit; }

void HybridBroadPhase::swap_pairs(std::vector<Pair>& other) { impl_->writer.pairs().swap(other); }

}  // namespace hbp
