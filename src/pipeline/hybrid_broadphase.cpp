// SPDX-License-Identifier: MIT
// The hybrid system's frame, top to bottom (run):
//   1. partition: the k-d tree maintained over this frame's boxes (or cells
//      partitioned elsewhere, or none at all for a one-cell frame);
//   2. engine over the cells: each cell loaded in min-x order and run
//      through its worker's engine (cell_pairs.hpp), in parallel;
//   3. one pair writer: cell c's pairs land at offsets[c] of the frame's
//      list, the sum of the pairs of the cells before it, so the list is the
//      same, in the same order, for any thread count. A steady frame writes
//      its cells in place (the lanes, in the last frame's list); a cell that
//      finds no room falls back to its worker's store, copied at the merge;
//      a cell too dense to store is counted, then written by a second
//      kernel run.
//   4. the list sorted by (a, b) when options().sorted.
// Streamed frames (a sink or parallel consumer) keep a list per cell and
// gather them at the merge.
#include "hbp/hybrid_broadphase.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "hbp/error.hpp"
#include "hbp/kd_partition.hpp"
#include "partition/raw_buffer.hpp"
#include "pipeline/arena_threads.hpp"
#include "pipeline/cell_lanes.hpp"
#include "pipeline/cell_pairs.hpp"
#include "pipeline/cell_stream.hpp"
#include "pipeline/cell_worker.hpp"
#include "pipeline/frame_stats.hpp"
#include "pipeline/pair_block_move.hpp"
#include "pipeline/pair_outputs.hpp"
#include "pipeline/parallel_pair_sort.hpp"
#include "pipeline/screened_boxes.hpp"
#include "support/clock.hpp"
#include "support/huge_pages.hpp"
#include "support/prefault.hpp"
#include "support/retained.hpp"

namespace hbp {

using detail::CellOutcome;
using detail::Worker;
using detail::kKeepCellPairs;
using detail::kKeepPairs;

namespace {

// Frames whose cells hold fewer entries than this run the engine phase on the
// calling thread: below it, handing cells to workers costs more than the
// cells themselves.
constexpr std::uint64_t kSerialEntries = 16384;
// A cell's pairs go to its worker's store, then are copied to their place
// in the frame's list (unless a lane writes them in place); the stores are
// sized from the last frame's pair count. A frame with no such count (the
// first, or the first after a one-cell or streamed frame) would grow stores
// of hundreds of megabytes from nothing: there a cell with more than
// kStoredPairsPerBox pairs per box is "dense", its pairs are only counted in
// the first pass and written straight into the list in a second kernel run
// (every frame that way costs a second kernel run, about 60 ms a frame on
// the clustered scene against 12 ms for the copy: docs/hybrid-system.md,
// "Pair-dense frames").
constexpr std::size_t kStoredPairsPerBox = 4;
// Pairs a worker's store may write past what it has written before, per
// frame (128 MiB): a fresh store's pages cost a kernel zeroing on first
// touch, so a store of hundreds of megabytes warms up over several frames;
// cells past the budget are counted and written in the second pass, as on
// the first frame.
constexpr std::size_t kTouchPairsPerFrame = std::size_t{16} << 20;
// The back lane's block is moved in this many chunks a worker (for balance).
constexpr int kMoveChunksPerWorker = 4;

}  // namespace

struct HybridBroadPhase::Impl {
  BroadPhaseOptions options;
  std::unique_ptr<CellEngine> prototype;
  // The engine has a streaming door (CellHitStream), whose count and emit
  // calls the frame loop drives itself (the lanes in place, dense cells
  // counted); other engines take whole cells through find_owned_pairs.
  bool direct_kernel;
  std::uint32_t cell_limit;
  tbb::task_arena arena;
  KdPartition own_partition;
  bool partition_in_use = false;                  // own_partition holds a tree from an earlier frame
  bool refresh_in_engine = false;                 // own_partition's cells are refreshed as the engine takes them
  const KdPartition* partition = &own_partition;  // this frame's cells
  tbb::enumerable_thread_specific<Worker> workers;
  std::vector<CellOutcome> outcomes;       // per cell
  std::vector<std::vector<Pair>> cell_pairs;  // per cell, when a sink or consumer streams them
  std::vector<std::size_t> offsets;        // per cell: first pair in `pairs`
  std::vector<Pair> pairs;                 // the frame's output
  std::vector<Pair> sort_scratch;
  RawBuffer<Pair> move_scratch;  // pairs set aside while the back lane's block moves
  FrameStats stats;
  std::atomic<std::uint64_t> running_pairs{0};
  std::size_t last_frame_pairs = 0;  // the pair count of the last frame through run_cells
  bool count_dense_cells = false;    // this frame has no estimate: dense cells are counted, then written
  std::size_t in_place_pairs = 0;    // pairs the front lane wrote straight into `pairs` this frame
  std::size_t back_pairs = 0;        // pairs the back lane wrote into `pairs`, ending at back_window
  std::size_t back_window = 0;       // the list's length while the lanes ran

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
        direct_kernel(prototype->hit_stream() != nullptr),
        cell_limit(choose_limit(o, *prototype)),
        arena(detail::arena_threads(o.threads)),
        own_partition(cell_limit, prototype->x_split_weight(), cell_cost(o, *prototype)),
        workers([this] {
          Worker w;
          w.engine = prototype->clone();
          if (options.max_pairs) w.engine->set_pair_limit(options.max_pairs);
          w.direct = w.engine->hit_stream();
          return w;
        }) {}

  // ---- The frame -----------------------------------------------------------

  // A frame of boxes. Small frames stay on the calling thread: entering the
  // arena would wake its workers for nothing.
  void run_boxes(const BoxArray& boxes, bool checked, const PairSink& sink, const PairSink& consumer) {
    if (boxes.size() <= cell_limit)
      run(&boxes, nullptr, checked, sink, consumer);
    else
      arena.execute([&] { run(&boxes, nullptr, checked, sink, consumer); });
  }

  // checked: the boxes were screened by the caller (ValidatedBoxes).
  void run(const BoxArray* boxes, const KdPartition* shared, bool checked, const PairSink& sink,
           const PairSink& consumer) {
    running_pairs = 0;
    const auto t0 = SteadyClock::now();
    double partition_ms = 0, engine_ms = 0, merge_ms = 0;
    const bool one_cell = !shared && is_one_cell_frame(boxes);
    if (one_cell) {
      const auto t_engine = SteadyClock::now();
      run_one_cell(*boxes, checked, sink, consumer);
      engine_ms = ms_since(t_engine);
    } else {
      const auto t_partition = SteadyClock::now();
      partition_frame(boxes, shared, checked);
      partition_ms = ms_since(t_partition);
      run_cells_and_finish(sink, consumer, partition_ms, engine_ms, merge_ms);
    }
    const auto t_sort = SteadyClock::now();
    sort_output();
    const double sort_ms = ms_since(t_sort);
    last_frame_pairs = one_cell || sink || consumer ? 0 : pairs.size();
    release_worker_buffers();
    record_stats(one_cell, boxes ? boxes->size() : 0);
    stats.partition_ms = partition_ms;
    stats.engine_ms = engine_ms;
    stats.merge_ms = merge_ms;
    stats.sort_ms = sort_ms;
    stats.wall_ms = ms_since(t0);
  }

  // Frames the partition would leave as one cell: no partition, no workers.
  bool is_one_cell_frame(const BoxArray* boxes) const { return boxes && boxes->size() <= cell_limit; }

  void run_one_cell(const BoxArray& boxes, bool checked, const PairSink& sink, const PairSink& consumer) {
    if (!checked) detail::screen_boxes_serial(boxes);
    if (partition_in_use) own_partition.reset();  // its tree is stale by the next large frame
    partition_in_use = false;
    cell_pairs.clear();  // buffers of earlier, larger frames
    for (Worker& other : workers) other.stored.clear();
    Worker& w = workers.local();
    w.cell.load(boxes);
    if (w.direct) w.direct->owner_codes(w.cell.boxes(), CellRegion::everything(), w.codes);
    outcomes.assign(1, CellOutcome{});
    pairs.clear();
    retained::release(pairs, 0, kKeepPairs);
    emit_cell(w, CellRegion::everything(), pairs, outcomes[0]);
    if (consumer) consumer(0, pairs.data(), pairs.size());
    if (sink) sink(0, pairs.data(), pairs.size());
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

  // The engine stage with the partition's deferred refresh: completed after
  // it, or, when a cell throws (max_pairs), the half-refreshed tree dropped.
  void run_cells_and_finish(const PairSink& sink, const PairSink& consumer, double& partition_ms, double& engine_ms,
                            double& merge_ms) {
    try {
      run_cells(sink, consumer, engine_ms, merge_ms);
    } catch (...) {
      if (refresh_in_engine) {
        refresh_in_engine = false;
        own_partition.reset();
        partition_in_use = false;
      }
      throw;
    }
    if (!refresh_in_engine) return;
    refresh_in_engine = false;
    const auto t_finish = SteadyClock::now();
    own_partition.finish_update();
    partition_ms += ms_since(t_finish);
  }

  // Engine over the cells, then the merge: the first pass runs every cell
  // (in place where the lanes can, else into a store or counted), the
  // second copies stored cells to their place and writes the counted ones.
  void run_cells(const PairSink& sink, const PairSink& consumer, double& engine_ms, double& merge_ms) {
    const std::uint32_t cells = partition->cell_count();
    outcomes.assign(cells, CellOutcome{});
    const auto t_engine = SteadyClock::now();
    // Each path's buffers are emptied when the other path runs, so the
    // release at the end of the frame frees what this frame did not use.
    for (Worker& w : workers) {
      w.stored.clear();
      w.store_full = false;
    }
    count_dense_cells = last_frame_pairs == 0;
    in_place_pairs = 0;
    back_pairs = 0;
    // Two lanes in place store only the cells they find no room for: the
    // stores are not sized for a share of the frame.
    if (!(sink || consumer) && !(front_lane_allowed() && lane_count() == 2)) size_stores();
    if (sink || consumer) {
      stream_cells(sink, consumer);
      engine_ms = ms_since(t_engine);
      const auto t_merge = SteadyClock::now();
      gather_streamed();
      merge_ms = ms_since(t_merge);
      return;
    }
    cell_pairs.clear();
    // The last frame's list is dead now; one much larger than this frame
    // needs is released rather than kept as room.
    retained::release(pairs, last_frame_pairs, kKeepPairs);
    if (front_lane_allowed())
      run_lanes(cells);
    else
      for_each_cell(cells, [&](std::uint32_t c) { first_pass(c); });
    engine_ms = ms_since(t_engine);
    const auto t_merge = SteadyClock::now();
    size_output(cells);
    for_each_cell(cells, [&](std::uint32_t c) { second_pass(c); });
    merge_ms = ms_since(t_merge);
  }

  void sort_output() {
    if (options.sorted) parallel_sort_pairs(pairs, sort_scratch, arena);  // scratch: the list + a small tail
    retained::release(sort_scratch, options.sorted ? pairs.size() : 0, kKeepPairs);
    retained::release(move_scratch, move_scratch.size(), kKeepPairs);
    move_scratch.clear();
  }

  // ---- Cells through the engine ---------------------------------------------

  void charge(std::size_t pairs_added) {
    if (!options.max_pairs) return;
    const std::uint64_t total = running_pairs.fetch_add(pairs_added) + pairs_added;
    if (total > options.max_pairs)
      throw CapacityExceeded("frame has more than max_pairs = " + std::to_string(options.max_pairs) +
                             " overlapping pairs (stopped at " + std::to_string(total) + ")");
  }
  auto charger() {
    return [this](std::size_t n) { charge(n); };
  }

  // Appends the owned pairs (global ids, canonical) of the loaded cell to out.
  template <class Out>
  void emit_cell(Worker& w, const CellRegion& region, Out& out, CellOutcome& r) {
    detail::emit_cell(w, region, out, r, charger());
  }
  template <class Out>
  bool emit_direct(Worker& w, const CellRegion& region, Out& out, CellOutcome& r,
                   std::size_t limit = std::numeric_limits<std::size_t>::max()) {
    return detail::emit_direct(w, region, out, r, charger(), limit);
  }

  // Cell c for its first trip through the engine. On a maintained frame the
  // partition rewrites each cell (kept members with this frame's boxes, plus
  // newcomers) right here, so the engine reads it from the cache instead of
  // from memory after a pass over all cells.
  std::span<const CellEntry> engine_cell(std::uint32_t c) {
    return refresh_in_engine ? own_partition.refresh_cell(c) : partition->cell(c);
  }

  bool serial_engine_phase() const {
    return arena.max_concurrency() == 1 || partition->stats().entries < kSerialEntries;
  }

  template <class F>
  void for_each_cell(std::uint32_t cells, F&& f) {
    if (serial_engine_phase()) {
      for (std::uint32_t c = 0; c < cells; ++c) f(c);
      return;
    }
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, cells, 1), [&](const auto& r) {
      for (std::uint32_t c = r.begin(); c != r.end(); ++c) f(c);
    });
  }

  // Streaming: each cell's pairs in its own list, handed to the consumer
  // (any worker, right after the engine) and the sink (in cell order, while
  // later cells are still in the engine).
  void stream_cells(const PairSink& sink, const PairSink& consumer) {
    const std::uint32_t cells = partition->cell_count();
    cell_pairs.resize(cells);
    auto cell_task = [&](std::uint32_t c) {
      Worker& w = workers.local();
      std::vector<Pair>& out = cell_pairs[c];
      out.clear();
      detail::load_cell(w, engine_cell(c), partition->region(c));
      emit_cell(w, partition->region(c), out, outcomes[c]);
      if (consumer) consumer(c, out.data(), out.size());
    };
    if (!sink) {
      for_each_cell(cells, cell_task);
      return;
    }
    const auto tokens = static_cast<std::size_t>(2 * std::max(1, arena.max_concurrency()));
    detail::stream_in_cell_order(cells, tokens, cell_task,
                                 [&](std::uint32_t c) { sink(c, cell_pairs[c].data(), cell_pairs[c].size()); });
  }

  // Copies the streamed cells' lists into the frame's list, in cell order.
  void gather_streamed() {
    const std::uint32_t cells = partition->cell_count();
    size_output(cells);
    for_each_cell(cells, [&](std::uint32_t c) {
      std::vector<Pair>& v = cell_pairs[c];
      if (!v.empty()) std::memcpy(pairs.data() + offsets[c], v.data(), v.size() * sizeof(Pair));
      retained::release(v, v.size(), kKeepCellPairs);
    });
  }

  // ---- The pair writer: stores ------------------------------------------------

  // First pass: every cell through the engine, its pairs appended to the
  // worker's store; on a frame without an estimate, dense cells are only
  // counted (see kStoredPairsPerBox). `loaded`: the front lane already
  // loaded (and refreshed) the cell into this worker and gave it up.
  void first_pass(std::uint32_t c, bool loaded = false) {
    Worker& w = workers.local();
    CellOutcome& r = outcomes[c];
    const CellRegion& region = partition->region(c);
    if (!loaded) detail::load_cell(w, engine_cell(c), region);
    r.stored = &w.stored;
    r.offset = w.stored.size();
    if (!w.direct || (!count_dense_cells && options.max_pairs)) {
      emit_cell(w, region, w.stored, r);  // (max_pairs: stores grow, see below)
      return;
    }
    if (!count_dense_cells && !w.store_full && store_within_budget(w, region, r)) return;
    const std::uint32_t n = w.cell.size();
    const std::size_t room = kStoredPairsPerBox * n + n + CellHitStream::kOutputSlack;
    detail::fit_stage(w, std::max(room, detail::stage_pairs(n)));
    std::size_t count = 0;
    std::uint32_t row =
        w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, 0, w.first.data(), w.second.data(), room, count);
    const bool over_budget = w.store_full && w.stored.size() + count > w.stored.capacity();
    if ((row < n || over_budget) && !options.max_pairs) {
      // Dense (or past a spent budget): count now, write in the second pass. (With max_pairs set, a
      // pair explosion must stop as soon as the limit is passed, not after
      // counting every pair: such cells keep storing, charged per drain.)
      count += w.direct->count_pairs(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, row);
      r.stored = nullptr;
      r.pairs = r.candidates = count;
      return;
    }
    while (true) {
      charge(count);
      detail::drain_stage(w, count, w.stored);
      r.pairs += count;
      if (row >= n) break;
      count = 0;
      row = w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, row, w.first.data(), w.second.data(),
                                w.first.size(), count);
    }
    r.candidates = r.pairs;
  }

  // Stores the cell's pairs while the worker's touch budget lasts; past it
  // the cell's pairs are dropped from the store, the budget marked spent and
  // false returned (the caller counts the cell instead).
  bool store_within_budget(Worker& w, const CellRegion& region, CellOutcome& r) {
    const std::size_t budget = std::min(w.stored.capacity(), w.touched + kTouchPairsPerFrame);
    if (emit_direct(w, region, w.stored, r, budget)) return true;
    w.store_full = true;
    return false;
  }

  // Second pass: stored pairs are copied to their place in the frame's list
  // (cell order: the same list for any thread count); dense cells run their
  // kernel again, draining the stage there.
  void second_pass(std::uint32_t c) {
    const CellOutcome& r = outcomes[c];
    Pair* dst = pairs.data() + offsets[c];
    if (r.in_place) return;
    if (r.stored) {
      if (r.pairs) std::memcpy(dst, r.stored->data() + r.offset, r.pairs * sizeof(Pair));
      return;
    }
    Worker& w = workers.local();
    detail::load_cell(w, partition->cell(c), partition->region(c));
    const std::uint32_t n = w.cell.size();
    detail::fit_stage(w, detail::stage_pairs(n));
    std::size_t written = 0;
    for (std::uint32_t row = 0; row < n;) {
      std::size_t count = 0;
      row = w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), partition->region(c), row, w.first.data(),
                                w.second.data(), w.first.size(), count);
      if (written + count > r.pairs) throw std::logic_error("hybrid broad phase: cell pair count changed");
      CellHitStream::write_pairs(w.first.data(), w.second.data(), count, dst + written);
      written += count;
    }
    if (written != r.pairs) throw std::logic_error("hybrid broad phase: cell pair count changed");
  }

  // Room in every worker's store for its likely share of this frame's
  // pairs (the last frame's count, split evenly, plus an eighth), so a
  // steady frame does not grow stores as it goes.
  std::size_t store_share() const {
    const auto workers_n = static_cast<std::size_t>(serial_engine_phase() ? 1 : std::max(1, arena.max_concurrency()));
    return last_frame_pairs / workers_n + last_frame_pairs / 8;
  }

  // Before the first pass (stores empty): a store below the share less half
  // its headroom is replaced by one of exactly the share, so a pair count
  // creeping up frame after frame neither reallocates every frame nor
  // doubles the stores (a fresh store is page faults on every page).
  void size_stores() {
    const std::size_t share = store_share();
    for (Worker& w : workers)
      if (w.stored.capacity() + last_frame_pairs / 16 < share) {
        w.stored.reserve(share);
        w.touched = 0;
      }
  }

  // Per-worker buffers follow this frame's needs.
  void release_worker_buffers() {
    for (Worker& w : workers) {
      w.touched = std::max(w.touched, w.stored.size());
      retained::release(w.stored, std::max(w.stored.size(), store_share()), kKeepPairs);
      if (w.stored.capacity() == 0) w.touched = 0;
      retained::release(w.local, w.local.size(), kKeepPairs);
    }
  }

  // ---- The pair writer: in place (cell_lanes.hpp) -----------------------------
  //
  // The front lane writes straight into the last frame's list; with two
  // lanes the back lane's cells go through the worker's store one cell at a
  // time (the store is as large as the largest cell and stays in cache) into
  // the back of the list. The two blocks share the old list's length
  // (ListRoom).

  bool front_lane_allowed() const { return direct_kernel && !count_dense_cells && !options.max_pairs && !pairs.empty(); }

  // Lanes of this frame when the front lane runs.
  int lane_count() const { return serial_engine_phase() ? 1 : std::max(1, arena.max_concurrency()); }

  void run_lanes(std::uint32_t cells) {
    const std::size_t window = pairs.size();
    detail::ListRoom room{window};
    detail::ListFront front{pairs.data(), 0, &room};
    detail::ListBack back{pairs.data() + window, 0, &room};
    detail::run_lanes(
        cells, lane_count(), window > 0, [&](std::uint32_t c) { return front_cell(c, front); },
        [&](std::uint32_t c) { return back_cell(c, back); }, [&](std::uint32_t c, bool loaded) { first_pass(c, loaded); });
    in_place_pairs = front.used;
    back_pairs = back.used;
    back_window = window;
  }

  // Cell c's pairs straight into the list after the front lane's earlier
  // cells; false (nothing kept, the cell stays loaded) when they would pass
  // the room left.
  bool front_cell(std::uint32_t c, detail::ListFront& front) {
    Worker& w = workers.local();
    CellOutcome& r = outcomes[c];
    const CellRegion& region = partition->region(c);
    detail::load_cell(w, engine_cell(c), region);
    if (!emit_direct(w, region, front, r)) return false;
    r.in_place = true;
    return true;
  }

  // Cell c's pairs into the worker's store, then, room permitting, copied
  // into the list just below the back lane's earlier cells (and dropped from
  // the store); false when there was no room: the cell stays stored.
  bool back_cell(std::uint32_t c, detail::ListBack& back) {
    Worker& w = workers.local();
    CellOutcome& r = outcomes[c];
    const CellRegion& region = partition->region(c);
    detail::load_cell(w, engine_cell(c), region);
    const std::size_t start = w.stored.size();
    r.stored = &w.stored;
    r.offset = start;
    emit_direct(w, region, w.stored, r);
    w.touched = std::max(w.touched, w.stored.size());
    if (!back.room->take(r.pairs)) return false;
    back.used += r.pairs;
    if (r.pairs) std::memcpy(back.end - back.used, w.stored.data() + start, r.pairs * sizeof(Pair));
    w.stored.truncate(start);
    r.stored = nullptr;
    r.in_place = true;
    return true;
  }

  // ---- The frame's list --------------------------------------------------------

  // Offsets of each cell's pairs in the frame's list, and the list sized.
  void size_output(std::uint32_t cells) {
    offsets.resize(std::size_t{cells} + 1);
    offsets[0] = 0;
    for (std::uint32_t c = 0; c < cells; ++c) offsets[c + 1] = offsets[c] + outcomes[c].pairs;
    const std::size_t total = offsets[cells];
    if (options.max_pairs && total > options.max_pairs)
      throw CapacityExceeded("frame has " + std::to_string(total) + " overlapping pairs, above max_pairs = " +
                             std::to_string(options.max_pairs));
    if (!in_place_pairs && !back_pairs) {
      reserve_output(total);
      pairs.resize(total);
      return;
    }
    // The lanes' cells are in place: keep them (growing copies), and move
    // the back lane's block to end where the list ends (before the stored
    // cells are copied in below it: growing, it leaves where they go).
    const std::size_t from = back_window - back_pairs, to = total - back_pairs;
    if (to <= from) {
      move_pairs(from, to, back_pairs);
      pairs.resize(total);
    } else {
      if (total > pairs.capacity()) pairs.reserve(total + total / 8);
      pairs.resize(total);
      move_pairs(from, to, back_pairs);
    }
  }

  void move_pairs(std::size_t from, std::size_t to, std::size_t count) {
    const auto chunks = static_cast<std::size_t>(kMoveChunksPerWorker * std::max(1, arena.max_concurrency()));
    detail::move_pair_block(pairs.data(), from, to, count, serial_engine_phase(), chunks, move_scratch);
  }

  // Room for this frame's pairs. Growing reallocates without copying (the
  // old pairs are overwritten anyway) and leaves headroom, so a pair count
  // creeping up frame after frame does not reallocate every frame; large
  // lists ask for transparent huge pages (a pair-dense frame's list is
  // hundreds of megabytes: 512 times fewer page faults on the first frame)
  // and are faulted in from every worker (the resize that follows would
  // otherwise take every fault on one thread).
  void reserve_output(std::size_t total) {
    retained::release(pairs, total, kKeepPairs);
    if (total <= pairs.capacity()) return;
    std::vector<Pair>().swap(pairs);
    pairs.reserve(detail::list_capacity(total + total / 8));
    advise_huge_pages(pairs.data(), pairs.capacity() * sizeof(Pair));
    if (total * sizeof(Pair) >= detail::kPrefaultBytes && !serial_engine_phase())
      prefault_pages(pairs.data(), total * sizeof(Pair));
  }

  // ---- Stats -------------------------------------------------------------------

  void record_stats(bool one_cell, std::size_t objects) {
    std::uint64_t cycles = 0, cand = 0;
    for (const CellOutcome& r : outcomes) {
      cycles += r.cycles;
      cand += r.candidates;
    }
    stats.pairs = pairs.size();
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
  return impl_->pairs;
}

const std::vector<Pair>& HybridBroadPhase::update(const ValidatedBoxes& boxes, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->run_boxes(boxes.boxes(), true, sink, parallel_consumer);
  return impl_->pairs;
}

const std::vector<Pair>& HybridBroadPhase::update(const KdPartition& cells, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->arena.execute([&] { impl_->run(nullptr, &cells, false, sink, parallel_consumer); });
  return impl_->pairs;
}
void HybridBroadPhase::reserve(std::size_t objects) {
  // A frame of at most cell_limit objects is one cell, not partitioned (the
  // partition checks the object limit).
  if (objects <= impl_->cell_limit) return;
  impl_->arena.execute([&] { impl_->own_partition.reserve(objects); });
}

const std::vector<Pair>& HybridBroadPhase::pairs() const { return impl_->pairs; }
const FrameStats& HybridBroadPhase::stats() const { return impl_->stats; }
const BroadPhaseOptions& HybridBroadPhase::options() const { return impl_->options; }
std::uint32_t HybridBroadPhase::cell_limit() const { return impl_->cell_limit; }

void HybridBroadPhase::swap_pairs(std::vector<Pair>& other) { impl_->pairs.swap(other); }

}  // namespace hbp
