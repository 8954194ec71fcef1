// SPDX-License-Identifier: MIT
#include "pipeline/frame_pair_writer.hpp"

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "hbp/error.hpp"
#include "pipeline/cell_lanes.hpp"
#include "pipeline/cell_pairs.hpp"
#include "pipeline/cell_stream.hpp"
#include "pipeline/pair_block_move.hpp"
#include "pipeline/tiled_cells.hpp"
#include "support/clock.hpp"
#include "support/huge_pages.hpp"
#include "support/parallel_for.hpp"
#include "support/prefault.hpp"
#include "support/retained.hpp"

namespace hbp::detail {

namespace {

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
// An engine without the streaming door takes consecutive cells in batches
// of about this many boxes (at least one cell; fewer boxes when that leaves
// each worker a few batches), one find_owned_pairs_batch call each.
constexpr std::size_t kBatchBoxes = std::size_t{1} << 16;
constexpr std::size_t kBatchesPerWorker = 4;

}  // namespace

FramePairWriter::FramePairWriter(Workers& workers, bool direct_kernel, std::uint64_t max_pairs)
    : workers_(workers), direct_kernel_(direct_kernel), max_pairs_(max_pairs) {}

// ---- Frames ------------------------------------------------------------------

void FramePairWriter::write_one_cell(Worker& w, const PairSink& sink, const PairSink& consumer) {
  running_pairs_ = 0;
  cell_pairs_.clear();  // buffers of earlier, larger frames
  for (Worker& other : workers_) other.stored.clear();
  outcomes_.assign(1, CellOutcome{});
  pairs_.clear();
  retained::release(pairs_, 0, kKeepPairs);
  emit_cell(w, CellRegion::everything(), pairs_, outcomes_[0], charger());
  if (consumer) consumer(0, pairs_.data(), pairs_.size());
  if (sink) sink(0, pairs_.data(), pairs_.size());
}

// Each path's buffers are emptied when the other path runs, so the release
// at the end of the frame frees what this frame did not use.
void FramePairWriter::begin_cells(const FrameCells& cells) {
  cells_ = cells;
  running_pairs_ = 0;
  outcomes_.assign(cells_.count(), CellOutcome{});
  for (Worker& w : workers_) {
    w.stored.clear();
    w.store_full = false;
  }
  count_dense_cells_ = last_frame_pairs_ == 0;
  in_place_pairs_ = 0;
  back_pairs_ = 0;
}

// The first pass runs every cell (in place where the lanes can, else into a
// store or counted), the second copies stored cells to their place and
// writes the counted ones.
FramePairWriter::StageTimes FramePairWriter::write_cells(const FrameCells& cells) {
  const auto t_engine = SteadyClock::now();
  begin_cells(cells);
  // Two lanes in place store only the cells they find no room for: the
  // stores are not sized for a share of the frame.
  if (!(front_lane_allowed() && cells_.lanes == 2)) size_stores();
  cell_pairs_.clear();
  // The last frame's list is dead now; one much larger than this frame
  // needs is released rather than kept as room.
  retained::release(pairs_, last_frame_pairs_, kKeepPairs);
  if (!direct_kernel_)
    store_batches();
  else if (front_lane_allowed())
    run_lanes();
  else
    for_each_cell([&](std::uint32_t c) { first_pass(c); });
  StageTimes t;
  t.engine_ms = ms_since(t_engine);
  const auto t_merge = SteadyClock::now();
  size_output();
  for_each_cell([&](std::uint32_t c) { second_pass(c); });
  t.merge_ms = ms_since(t_merge);
  return t;
}

FramePairWriter::StageTimes FramePairWriter::stream_cells(const FrameCells& cells, const PairSink& sink,
                                                          const PairSink& consumer) {
  const auto t_engine = SteadyClock::now();
  begin_cells(cells);
  const std::uint32_t count = cells_.count();
  cell_pairs_.resize(count);
  auto cell_task = [&](std::uint32_t c) {
    Worker& w = workers_.local();
    std::vector<Pair>& out = cell_pairs_[c];
    out.clear();
    load_cell(w, cells_.engine_cell(c), cells_.region(c));
    emit_cell(w, cells_.region(c), out, outcomes_[c], charger());
    if (consumer) consumer(c, out.data(), out.size());
  };
  if (!sink) {
    for_each_cell(cell_task);
  } else {
    const auto tokens = static_cast<std::size_t>(2 * cells_.lanes);
    stream_in_cell_order(count, tokens, cell_task,
                         [&](std::uint32_t c) { sink(c, cell_pairs_[c].data(), cell_pairs_[c].size()); });
  }
  StageTimes t;
  t.engine_ms = ms_since(t_engine);
  const auto t_merge = SteadyClock::now();
  size_output();
  for_each_cell([&](std::uint32_t c) {
    std::vector<Pair>& v = cell_pairs_[c];
    if (!v.empty()) std::memcpy(pairs_.data() + offsets_[c], v.data(), v.size() * sizeof(Pair));
    retained::release(v, v.size(), kKeepCellPairs);
  });
  t.merge_ms = ms_since(t_merge);
  return t;
}

void FramePairWriter::end_frame(bool estimate) {
  last_frame_pairs_ = estimate ? pairs_.size() : 0;
  retained::release(move_scratch_, move_scratch_.size(), kKeepPairs);
  move_scratch_.clear();
  for (Worker& w : workers_) {
    w.touched = std::max(w.touched, w.stored.size());
    retained::release(w.stored, std::max(w.stored.size(), store_share()), kKeepPairs);
    if (w.stored.capacity() == 0) w.touched = 0;
    retained::release(w.local, w.local.size(), kKeepPairs);
  }
}

void FramePairWriter::charge(std::size_t pairs_added) {
  if (!max_pairs_) return;
  const std::uint64_t total = running_pairs_.fetch_add(pairs_added) + pairs_added;
  if (total > max_pairs_)
    throw CapacityExceeded("frame has more than max_pairs = " + std::to_string(max_pairs_) +
                           " overlapping pairs (stopped at " + std::to_string(total) + ")");
}

template <class F>
void FramePairWriter::for_each_cell(F&& f) {
  const std::uint32_t count = cells_.count();
  if (cells_.lanes == 1) {
    for (std::uint32_t c = 0; c < count; ++c) f(c);
    return;
  }
  parallel_for_each(count, [&](std::size_t c) { f(static_cast<std::uint32_t>(c)); });
}

// ---- The stores ----------------------------------------------------------------

// Engines without the streaming door: the cells cut into batches of
// consecutive cells (the cut does not change any cell's pairs), each batch
// through one find_owned_pairs_batch call, its pairs stored.
void FramePairWriter::store_batches() {
  const std::uint32_t count = cells_.count();
  std::size_t entries = 0;
  for (std::uint32_t c = 0; c < count; ++c) entries += cells_.partition->cell(c).size();
  const std::size_t batch_boxes = std::clamp<std::size_t>(
      entries / (kBatchesPerWorker * static_cast<std::size_t>(cells_.lanes)), 1, kBatchBoxes);
  batch_starts_.assign(1, 0);
  std::size_t boxes = 0;
  for (std::uint32_t c = 0; c < count; ++c) {
    boxes += cells_.partition->cell(c).size();
    if (boxes >= batch_boxes || c + 1 == count) {
      batch_starts_.push_back(c + 1);
      boxes = 0;
    }
  }
  const auto batches = static_cast<std::uint32_t>(batch_starts_.size() - 1);
  const auto run = [&](std::uint32_t b) { store_batch(batch_starts_[b], batch_starts_[b + 1]); };
  if (cells_.lanes == 1) {
    for (std::uint32_t b = 0; b < batches; ++b) run(b);
    return;
  }
  parallel_for_each(batches, [&](std::size_t b) { run(static_cast<std::uint32_t>(b)); });
}

// Cells [first, end): each loaded in min-x order and appended to the
// worker's batch (a cell past the engine's capacity is tiled on its own),
// the batch run, and each cell's pairs mapped to ids into the store.
void FramePairWriter::store_batch(std::uint32_t first, std::uint32_t end) {
  Worker& w = workers_.local();
  Worker::Batch& b = w.batch;
  b.boxes.clear();
  b.ids.clear();
  b.starts.assign(1, 0);
  b.cells.clear();
  b.regions.clear();
  for (std::uint32_t c = first; c < end; ++c) {
    const CellRegion& region = cells_.region(c);
    load_cell(w, cells_.engine_cell(c), region);
    const std::uint32_t n = w.cell.size();
    if (n > w.engine->capacity()) {
      CellOutcome& r = outcomes_[c];
      r.stored = &w.stored;
      r.offset = w.stored.size();
      emit_tiled(w, region, w.stored, r, charger());
      continue;
    }
    const std::uint32_t at = b.starts.back();
    b.boxes.resize(at + n);
    for (int axis = 0; axis < 3; ++axis) {
      std::copy_n(w.cell.boxes().min(axis), n, b.boxes.min(axis) + at);
      std::copy_n(w.cell.boxes().max(axis), n, b.boxes.max(axis) + at);
    }
    b.ids.insert(b.ids.end(), w.cell.ids(), w.cell.ids() + n);
    b.starts.push_back(at + n);
    b.cells.push_back(c);
    b.regions.push_back(region);
  }
  if (b.cells.empty()) return;
  b.outcomes.resize(b.cells.size());
  w.local.clear();
  w.engine->find_owned_pairs_batch(CellBatch{&b.boxes, b.starts, b.regions}, w.local, b.outcomes);
  charge(w.local.size());
  std::size_t begin = 0;
  for (std::size_t k = 0; k < b.cells.size(); ++k) {
    CellOutcome& r = outcomes_[b.cells[k]];
    const std::size_t cell_end = b.outcomes[k].end;
    const std::uint32_t* ids = b.ids.data() + b.starts[k];
    r.stored = &w.stored;
    r.offset = w.stored.size();
    for (std::size_t p = begin; p < cell_end; ++p) append(w.stored, make_pair(ids[w.local[p].a], ids[w.local[p].b]));
    r.pairs = r.candidates = cell_end - begin;
    r.cycles = b.outcomes[k].run.cycles;
    begin = cell_end;
  }
}

// Every cell through the engine, its pairs appended to the worker's store;
// on a frame without an estimate, dense cells are only counted (see
// kStoredPairsPerBox). `loaded`: the front lane already loaded (and
// refreshed) the cell into this worker and gave it up.
void FramePairWriter::first_pass(std::uint32_t c, bool loaded) {
  Worker& w = workers_.local();
  CellOutcome& r = outcomes_[c];
  const CellRegion& region = cells_.region(c);
  if (!loaded) load_cell(w, cells_.engine_cell(c), region);
  r.stored = &w.stored;
  r.offset = w.stored.size();
  if (!w.direct || (!count_dense_cells_ && max_pairs_)) {
    emit_cell(w, region, w.stored, r, charger());  // (max_pairs: stores grow, see below)
    return;
  }
  if (!count_dense_cells_ && !w.store_full && store_within_budget(w, region, r)) return;
  const std::uint32_t n = w.cell.size();
  const std::size_t room = kStoredPairsPerBox * n + n + CellHitStream::kOutputSlack;
  fit_stage(w, std::max(room, stage_pairs(n)));
  std::size_t count = 0;
  std::uint32_t row =
      w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, 0, w.first.data(), w.second.data(), room, count);
  const bool over_budget = w.store_full && w.stored.size() + count > w.stored.capacity();
  if ((row < n || over_budget) && !max_pairs_) {
    // Dense (or past a spent budget): count now, write in the second pass.
    // (With max_pairs set, a pair explosion must stop as soon as the limit
    // is passed, not after counting every pair: such cells keep storing,
    // charged per drain.)
    count += w.direct->count_pairs(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, row);
    r.stored = nullptr;
    r.pairs = r.candidates = count;
    return;
  }
  while (true) {
    charge(count);
    drain_stage(w, count, w.stored);
    r.pairs += count;
    if (row >= n) break;
    count = 0;
    row = w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, row, w.first.data(), w.second.data(),
                              w.first.size(), count);
  }
  r.candidates = r.pairs;
}

// Stores the cell's pairs while the worker's touch budget lasts; past it the
// cell's pairs are dropped from the store, the budget marked spent and false
// returned (the caller counts the cell instead).
bool FramePairWriter::store_within_budget(Worker& w, const CellRegion& region, CellOutcome& r) {
  const std::size_t budget = std::min(w.stored.capacity(), w.touched + kTouchPairsPerFrame);
  if (emit_direct(w, region, w.stored, r, charger(), budget)) return true;
  w.store_full = true;
  return false;
}

// Stored pairs are copied to their place in the frame's list (cell order:
// the same list for any thread count); dense cells run their kernel again,
// draining the stage there.
void FramePairWriter::second_pass(std::uint32_t c) {
  const CellOutcome& r = outcomes_[c];
  Pair* dst = pairs_.data() + offsets_[c];
  if (r.in_place) return;
  if (r.stored) {
    if (r.pairs) std::memcpy(dst, r.stored->data() + r.offset, r.pairs * sizeof(Pair));
    return;
  }
  Worker& w = workers_.local();
  const CellRegion& region = cells_.region(c);
  load_cell(w, cells_.partition->cell(c), region);
  const std::uint32_t n = w.cell.size();
  fit_stage(w, stage_pairs(n));
  std::size_t written = 0;
  for (std::uint32_t row = 0; row < n;) {
    std::size_t count = 0;
    row = w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, row, w.first.data(),
                              w.second.data(), w.first.size(), count);
    if (written + count > r.pairs) throw std::logic_error("hybrid broad phase: cell pair count changed");
    CellHitStream::write_pairs(w.first.data(), w.second.data(), count, dst + written);
    written += count;
  }
  if (written != r.pairs) throw std::logic_error("hybrid broad phase: cell pair count changed");
}

// Room in every worker's store for its likely share of this frame's pairs
// (the last frame's count, split evenly, plus an eighth), so a steady frame
// does not grow stores as it goes.
std::size_t FramePairWriter::store_share() const {
  const auto lanes = static_cast<std::size_t>(cells_.lanes);
  return last_frame_pairs_ / lanes + last_frame_pairs_ / 8;
}

// Before the first pass (stores empty): a store below the share less half
// its headroom is replaced by one of exactly the share, so a pair count
// creeping up frame after frame neither reallocates every frame nor doubles
// the stores (a fresh store is page faults on every page).
void FramePairWriter::size_stores() {
  const std::size_t share = store_share();
  for (Worker& w : workers_)
    if (w.stored.capacity() + last_frame_pairs_ / 16 < share) {
      w.stored.reserve(share);
      w.touched = 0;
    }
}

// ---- In place (cell_lanes.hpp) ---------------------------------------------------
//
// The front lane writes straight into the last frame's list; with two lanes
// the back lane's cells go through the worker's store one cell at a time
// (the store is as large as the largest cell and stays in cache) into the
// back of the list. The two blocks share the old list's length (ListRoom).

bool FramePairWriter::front_lane_allowed() const {
  return direct_kernel_ && !count_dense_cells_ && !max_pairs_ && !pairs_.empty();
}

void FramePairWriter::run_lanes() {
  const std::size_t window = pairs_.size();
  ListRoom room{window};
  ListFront front{pairs_.data(), 0, &room};
  ListBack back{pairs_.data() + window, 0, &room};
  detail::run_lanes(
      cells_.count(), cells_.lanes, window > 0, [&](std::uint32_t c) { return front_cell(c, front); },
      [&](std::uint32_t c) { return back_cell(c, back); }, [&](std::uint32_t c, bool loaded) { first_pass(c, loaded); });
  in_place_pairs_ = front.used;
  back_pairs_ = back.used;
  back_window_ = window;
}

// Cell c's pairs straight into the list after the front lane's earlier
// cells; false (nothing kept, the cell stays loaded) when they would pass the
// room left.
bool FramePairWriter::front_cell(std::uint32_t c, ListFront& front) {
  Worker& w = workers_.local();
  CellOutcome& r = outcomes_[c];
  const CellRegion& region = cells_.region(c);
  load_cell(w, cells_.engine_cell(c), region);
  if (!emit_direct(w, region, front, r, charger())) return false;
  r.in_place = true;
  return true;
}

// Cell c's pairs into the worker's store, then, room permitting, copied into
// the list just below the back lane's earlier cells (and dropped from the
// store); false when there was no room: the cell stays stored.
bool FramePairWriter::back_cell(std::uint32_t c, ListBack& back) {
  Worker& w = workers_.local();
  CellOutcome& r = outcomes_[c];
  const CellRegion& region = cells_.region(c);
  load_cell(w, cells_.engine_cell(c), region);
  const std::size_t start = w.stored.size();
  r.stored = &w.stored;
  r.offset = start;
  emit_direct(w, region, w.stored, r, charger());
  w.touched = std::max(w.touched, w.stored.size());
  if (!back.room->take(r.pairs)) return false;
  back.used += r.pairs;
  if (r.pairs) std::memcpy(back.end - back.used, w.stored.data() + start, r.pairs * sizeof(Pair));
  w.stored.truncate(start);
  r.stored = nullptr;
  r.in_place = true;
  return true;
}

// ---- The frame's list ------------------------------------------------------------

// Offsets of each cell's pairs in the frame's list, and the list sized.
void FramePairWriter::size_output() {
  const std::uint32_t count = cells_.count();
  offsets_.resize(std::size_t{count} + 1);
  offsets_[0] = 0;
  for (std::uint32_t c = 0; c < count; ++c) offsets_[c + 1] = offsets_[c] + outcomes_[c].pairs;
  const std::size_t total = offsets_[count];
  if (max_pairs_ && total > max_pairs_)
    throw CapacityExceeded("frame has " + std::to_string(total) + " overlapping pairs, above max_pairs = " +
                           std::to_string(max_pairs_));
  if (!in_place_pairs_ && !back_pairs_) {
    reserve_output(total);
    pairs_.resize(total);
    return;
  }
  // The lanes' cells are in place: keep them (growing copies), and move the
  // back lane's block to end where the list ends (before the stored cells
  // are copied in below it: growing, it leaves where they go).
  const std::size_t from = back_window_ - back_pairs_, to = total - back_pairs_;
  if (to <= from) {
    move_pairs(from, to, back_pairs_);
    pairs_.resize(total);
  } else {
    if (total > pairs_.capacity()) pairs_.reserve(total + total / 8);
    pairs_.resize(total);
    move_pairs(from, to, back_pairs_);
  }
}

void FramePairWriter::move_pairs(std::size_t from, std::size_t to, std::size_t count) {
  const auto chunks = static_cast<std::size_t>(kMoveChunksPerWorker * cells_.lanes);
  move_pair_block(pairs_.data(), from, to, count, cells_.lanes == 1, chunks, move_scratch_);
}

// Room for this frame's pairs. Growing reallocates without copying (the old
// pairs are overwritten anyway) and leaves headroom, so a pair count creeping
// up frame after frame does not reallocate every frame; large lists ask for
// transparent huge pages (a pair-dense frame's list is hundreds of
// megabytes: 512 times fewer page faults on the first frame) and are faulted
// in from every worker (the resize that follows would otherwise take every
// fault on one thread).
void FramePairWriter::reserve_output(std::size_t total) {
  retained::release(pairs_, total, kKeepPairs);
  if (total <= pairs_.capacity()) return;
  std::vector<Pair>().swap(pairs_);
  pairs_.reserve(list_capacity(total + total / 8));
  advise_huge_pages(pairs_.data(), pairs_.capacity() * sizeof(Pair));
  if (total * sizeof(Pair) >= kPrefaultBytes && cells_.lanes > 1) prefault_pages(pairs_.data(), total * sizeof(Pair));
}

}  // namespace hbp::detail
