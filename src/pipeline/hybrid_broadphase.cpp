// SPDX-License-Identifier: MIT
#include "hbp/hybrid_broadphase.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "hbp/error.hpp"
#include "hbp/kd_partition.hpp"
#include "geometry/box_screen.hpp"
#include "pipeline/arena_threads.hpp"
#include "pipeline/hybrid_access.hpp"
#include "partition/raw_buffer.hpp"
#include "pipeline/ordered_cell.hpp"
#include "pipeline/parallel_pair_sort.hpp"
#include "support/clock.hpp"
#include "support/huge_pages.hpp"
#include "support/prefault.hpp"
#include "support/retained.hpp"

namespace hbp {

namespace {


// Frames whose cells hold fewer entries than this run the engine phase on the
// calling thread: below it, handing cells to workers costs more than the
// cells themselves.
constexpr std::uint64_t kSerialEntries = 16384;
// The kernel's output lands in a cache-resident stage before it moves on
// (4 K pairs: first + second fit L1 beside the cell; 16 K cost ~4 % more
// CPU on clustered 1,000,000, see docs/hybrid-system.md "Pair-dense frames").
constexpr std::size_t kStagePairs = 1 << 12;
// Output: a cell's pairs go to its worker's store, then are copied to
// their place in the frame's list (unless a lane writes them in place, see
// "The lanes writing in place"); the stores are sized from the last frame's
// pair count. A frame with no such count (the first, or the first
// after a one-cell or streamed frame) would grow stores of hundreds of
// megabytes from nothing: there a cell with more than kStoredPairsPerBox
// pairs per box is "dense", its pairs are only counted in the first pass
// and written straight into the list in a second kernel run. (Every frame
// that way costs a second kernel run, about 60 ms a frame on the clustered
// scene against 12 ms for the copy: docs/hybrid-system.md, "Pair-dense
// frames".)
constexpr std::size_t kStoredPairsPerBox = 4;
// Pairs a worker's store may write past what it has written before, per
// frame (128 MiB): a fresh store's pages cost a kernel zeroing on first
// touch (well under 1 GB/s on the VM measured), so a store of hundreds of
// megabytes warms up over several frames; cells past the budget are counted
// and written in the second pass, as on the first frame.
constexpr std::size_t kTouchPairsPerFrame = std::size_t{16} << 20;
// Pair buffers kept from frame to frame follow the retained rule
// (support/retained.hpp) with its default slack; a list kept per cell
// (there are thousands) with a smaller one.
constexpr std::size_t kKeepPairs = retained::kSlack<Pair>;
constexpr std::size_t kKeepCellPairs = 1 << 10;
// Fresh output lists of at least this many bytes are faulted in by all
// workers at once (see prefault).
constexpr std::size_t kPrefaultBytes = std::size_t{8} << 20;
// The back lane's block is moved on all workers from this many pairs (512 KiB),
// in this many chunks a worker (for balance), each chunk at least this many
// times the distance moved (what a chunk sets aside: at most an eighth of
// the block).
constexpr std::size_t kMoveParallelPairs = std::size_t{1} << 16;
constexpr int kMoveChunksPerWorker = 4;
constexpr std::size_t kMoveChunksPerShift = 8;
// A frame with no last count whose cells were built this frame (the first
// frame) sizes its list from a count of every kFirstFrameSampleStride-th
// cell, scaled by entries and given a margin of 1/kFirstFrameMargin, and runs
// the two lanes in place (see first_frame_list).
constexpr std::uint32_t kFirstFrameSampleStride = 8;
constexpr std::size_t kFirstFrameMargin = 32;

// The frame's list is a std::vector (the public type of pairs()), from
// malloc. A capacity of whole 2 MiB pages: glibc maps the block on its own as
// that plus its header's 4 KiB page, and Linux places a new mapping top-down
// with its end at the start of a mapping above or of a gap, which for our
// large buffers (whole 2 MiB pages, 2 MiB-aligned) is a 2 MiB boundary; the
// list then starts 4 KiB - 16 bytes below a boundary, and every 2 MiB past it
// can be a huge page (at an arbitrary size the list's first partial 2 MiB
// would be pages of 4 KiB, each a fault costing microseconds on our VMs,
// warm or cold). Where the guess is wrong, only the capacity differs. Lists under kPrefaultBytes keep their size (rounded up,
// a small list's capacity would pass twice its size, and
// retained::release would free and map it again every frame).
std::size_t list_capacity(std::size_t want) {
  static_assert(kHugePageBytes % sizeof(Pair) == 0);
  if (want * sizeof(Pair) < kPrefaultBytes) return want;
  return whole_huge_pages(want * sizeof(Pair)) / sizeof(Pair);
}

// The frame's boxes screened in parallel; on failure the serial validate()
// names the object.
void validate_boxes(const BoxArray& boxes) {
  const bool bad = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, boxes.size(), 16384), false,
      [&](const auto& r, bool acc) { return acc || geometry::screen_fails(boxes, r.begin(), r.end()); },
      [](bool a, bool b) { return a || b; });
  if (bad) boxes.validate("frame");
}

// The same on the calling thread (one-cell frames: small worlds).
void validate_boxes_serial(const BoxArray& boxes) {
  if (geometry::screen_fails(boxes, 0, boxes.size())) boxes.validate("frame");
}

struct Worker {
  std::unique_ptr<CellEngine> engine;
  const CellHitStream* direct = nullptr;  // the engine's streaming door, when it has one
  OrderedCell cell;                        // the cell being processed, in min-x order
  std::vector<std::uint32_t> codes;        // its boxes' owner codes (streaming engines)
  std::vector<std::uint32_t> first, second;  // kernel hits before they move on (the stage)
  std::vector<Pair> local;                 // other engines: pairs in local indices
  BoxArray tile;                           // other engines: two blocks of an over-full cell
  // This worker's cells' pairs, before the copy to the list (a RawBuffer:
  // huge pages when large, storage given back after a one-frame peak).
  RawBuffer<Pair> stored;
  std::size_t touched = 0;                 // entries of `stored`'s allocation written in earlier frames
  bool store_full = false;                 // this frame's touch budget is spent: dense cells are counted
};

// What one cell produced this frame.
struct CellOutcome {
  std::uint64_t pairs = 0;
  std::uint64_t candidates = 0;  // owned pairs the engine calls returned (tiled cells: summed over calls)
  std::uint64_t cycles = 0;
  // Where the cell's pairs wait for the copy into the frame's list, or
  // nullptr when the cell was only counted (first frame, spent touch budget)
  // and writes them in the second pass.
  const RawBuffer<Pair>* stored = nullptr;
  std::size_t offset = 0;
  bool in_place = false;  // written straight into the frame's list by the front lane
};

// Room in the last frame's list for the lanes writing in place: pairs not
// yet taken by the front lane (growing up from the list's start) or the back
// lane (growing down from its end). One counter for both, so the two blocks
// never overlap whatever order the lanes take their room in.
struct ListRoom {
  std::atomic<std::size_t> free;
  bool take(std::size_t count) {
    std::size_t r = free.load(std::memory_order_relaxed);
    while (r >= count)
      if (free.compare_exchange_weak(r, r - count, std::memory_order_relaxed)) return true;
    return false;
  }
  void give_back(std::size_t count) { free.fetch_add(count, std::memory_order_relaxed); }
};

// The front of the last frame's list, which the front lane overwrites with
// this frame's first cells (an output for emit_direct: never grows past its
// room).
struct ListFront {
  Pair* base;
  std::size_t used;
  ListRoom* room;
  std::size_t size() const { return used; }
};

// The back of the last frame's list, which the back lane (two lanes)
// overwrites with this frame's last cells, the last cell's pairs ending at
// `end`, the cell before it ending where those start, and so on; the merge
// moves the block to end where the frame's list ends.
struct ListBack {
  Pair* end;
  std::size_t used;  // the block is [end - used, end)
  ListRoom* room;
};

std::size_t stage_pairs(std::uint32_t n) {
  return std::max(kStagePairs, 2 * (std::size_t{n} + CellHitStream::kOutputSlack));
}

void fit_stage(Worker& w, std::size_t hits) {
  if (w.first.size() < hits || retained::oversized(w.first.size(), hits, kKeepPairs)) {
    w.first.assign(hits, 0);
    w.second.assign(hits, 0);
  }
}

// Grows v's capacity to at least `want`, keeping its pairs: at least
// twofold (unless told the exact size), and a large store asks for
// transparent huge pages before the copy touches it (a worker's store of a
// dense frame is hundreds of megabytes of fresh pages, and a 4 KiB page costs
// ~14 us to fault on our machines).
void grow_pairs(std::vector<Pair>& v, std::size_t want, bool twofold = true) {
  if (want <= v.capacity()) return;
  std::vector<Pair> grown;
  grown.reserve(twofold ? std::max(want, 2 * v.capacity()) : want);
  advise_huge_pages(grown.data(), grown.capacity() * sizeof(Pair));
  grown.insert(grown.end(), v.begin(), v.end());
  v.swap(grown);
}

// Room for `count` more pairs at the end of out (uninitialised in a
// RawBuffer); returns where they go.
Pair* extend(std::vector<Pair>& out, std::size_t count) {
  const std::size_t base = out.size();
  grow_pairs(out, base + count);
  out.resize(base + count);
  return out.data() + base;
}
Pair* extend(RawBuffer<Pair>& out, std::size_t count) {
  const std::size_t base = out.size();
  out.grow(base + count);  // at least twofold when it reallocates
  return out.data() + base;
}
template <class Out>
void append(Out& out, Pair p) {
  *extend(out, 1) = p;
}
Pair* extend(ListFront& out, std::size_t count) {
  out.used += count;
  return out.base + out.used - count;
}
void truncate(std::vector<Pair>& out, std::size_t n) { out.resize(n); }
void truncate(ListFront& out, std::size_t n) {
  out.room->give_back(out.used - n);
  out.used = n;
}
void truncate(RawBuffer<Pair>& out, std::size_t n) { out.truncate(n); }
// Whether count more pairs fit in out below limit (the list's front: in
// the room the back lane left, which they then take).
template <class Out>
bool fits(Out& out, std::size_t count, std::size_t limit) {
  return out.size() + count <= limit;
}
bool fits(ListFront& out, std::size_t count, std::size_t) { return out.room->take(count); }

// Appends the stage's first `count` hits to out as canonical pairs.
template <class Out>
void drain_stage(const Worker& w, std::size_t count, Out& out) {
  CellHitStream::write_pairs(w.first.data(), w.second.data(), count, extend(out, count));
}

}  // namespace

struct HybridBroadPhase::Impl {
  BroadPhaseOptions options;
  std::unique_ptr<CellEngine> prototype;
  // The engine has a streaming door (CellHitStream), whose count and emit
  // calls the frame loop drives itself (the lanes in place, the sampled
  // first frame); other engines take whole cells through find_owned_pairs.
  bool direct_kernel;
  std::uint32_t cell_limit;
  tbb::task_arena arena;
  KdPartition own_partition;
  bool partition_in_use = false;                  // own_partition holds a tree from an earlier frame
  bool refresh_in_engine = false;                 // own_partition's cells are refreshed as the engine takes them
  bool boxes_checked = false;  // this frame's boxes were validated by the caller (HybridAccess)
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
  bool estimated_list = false;       // the lanes ran in a list sized from a sample (first frame)

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

  explicit Impl(const BroadPhaseOptions& o)
      : options(o),
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

  void charge(std::size_t pairs_added) {
    if (!options.max_pairs) return;
    const std::uint64_t total = running_pairs.fetch_add(pairs_added) + pairs_added;
    if (total > options.max_pairs)
      throw CapacityExceeded("frame has more than max_pairs = " + std::to_string(options.max_pairs) +
                             " overlapping pairs (stopped at " + std::to_string(total) + ")");
  }

  // ---- One cell through the engine ---------------------------------------

  // The cell in min-x order, and for a streaming engine its owner codes.
  static void load_cell(Worker& w, std::span<const CellEntry> entries, const CellRegion& region) {
    w.cell.load(entries);
    if (w.direct) w.direct->owner_codes(w.cell.boxes(), region, w.codes);
  }

  // Appends the owned pairs (global ids, canonical) of the loaded cell to out.
  template <class Out>
  void emit_cell(Worker& w, const CellRegion& region, Out& out, CellOutcome& r) {
    if (w.direct)
      emit_direct(w, region, out, r);
    else if (w.cell.size() <= w.engine->capacity())
      emit_whole(w, region, out, r);
    else
      emit_tiled(w, region, out, r);
  }

  // A streaming engine writes global ids into the stage; the stage drains
  // into out whenever it fills. Should out grow past `limit` pairs (a
  // store's touch budget), what the cell appended is taken back and false
  // returned.
  template <class Out>
  bool emit_direct(Worker& w, const CellRegion& region, Out& out, CellOutcome& r,
                   std::size_t limit = std::numeric_limits<std::size_t>::max()) {
    const std::size_t start = out.size();
    const std::uint64_t pairs_before = r.pairs;
    const std::uint32_t n = w.cell.size();
    fit_stage(w, stage_pairs(n));
    for (std::uint32_t row = 0; row < n;) {
      std::size_t count = 0;
      row = w.direct->emit_hits(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, row, w.first.data(), w.second.data(),
                                w.first.size(), count);
      if (!fits(out, count, limit)) {
        truncate(out, start);
        r.pairs = pairs_before;
        return false;
      }
      charge(count);
      drain_stage(w, count, out);
      r.pairs += count;
    }
    r.candidates = r.pairs;
    return true;
  }

  // Any other engine: local indices, mapped to ids.
  template <class Out>
  void emit_whole(Worker& w, const CellRegion& region, Out& out, CellOutcome& r) {
    w.local.clear();
    r.cycles += w.engine->find_owned_pairs(w.cell.boxes(), region, w.local).cycles;
    charge(w.local.size());
    const std::uint32_t* ids = w.cell.ids();
    for (const Pair& p : w.local) append(out, make_pair(ids[p.a], ids[p.b]));
    r.pairs += w.local.size();
    r.candidates += w.local.size();
  }

  // More objects than the engine holds (identical or nested boxes): run
  // every pair of blocks of cap/2 through the engine. Block i's own pairs
  // are kept from the run (i, i+1); the last block's from (k-2, k-1). Two
  // consecutive ranges of the min-x order are in min-x order together.
  template <class Out>
  void emit_tiled(Worker& w, const CellRegion& region, Out& out, CellOutcome& r) {
    const std::uint32_t n = w.cell.size();
    const std::uint32_t block = std::max<std::uint32_t>(1, w.engine->capacity() / 2);
    const std::uint32_t k = (n + block - 1) / block;
    const std::uint32_t* ids = w.cell.ids();
    for (std::uint32_t bi = 0; bi < k; ++bi) {
      for (std::uint32_t bj = bi + 1; bj < k; ++bj) {
        const std::uint32_t oi = bi * block, ni = std::min(block, n - oi);
        const std::uint32_t oj = bj * block, nj = std::min(block, n - oj);
        copy_tile(w, oi, ni, oj, nj);
        w.local.clear();
        r.cycles += w.engine->find_owned_pairs(w.tile, region, w.local).cycles;
        const std::size_t before = out.size();
        const bool keep_i = bj == bi + 1;
        const bool keep_j = bi + 2 == k && bj + 1 == k;
        auto id = [&](std::uint32_t local) { return ids[local < ni ? oi + local : oj + (local - ni)]; };
        for (const Pair& p : w.local) {
          const bool a_in_i = p.a < ni, b_in_i = p.b < ni;
          const bool keep = (a_in_i != b_in_i) || (a_in_i && keep_i) || (!a_in_i && keep_j);
          if (keep) append(out, make_pair(id(p.a), id(p.b)));
        }
        charge(out.size() - before);
        r.pairs += out.size() - before;
        r.candidates += w.local.size();
      }
    }
  }

  static void copy_tile(Worker& w, std::uint32_t oi, std::uint32_t ni, std::uint32_t oj, std::uint32_t nj) {
    const BoxArray& src = w.cell.boxes();
    w.tile.resize(ni + nj);
    for (int k = 0; k < 3; ++k) {
      std::copy_n(src.min(k) + oi, ni, w.tile.min(k));
      std::copy_n(src.min(k) + oj, nj, w.tile.min(k) + ni);
      std::copy_n(src.max(k) + oi, ni, w.tile.max(k));
      std::copy_n(src.max(k) + oj, nj, w.tile.max(k) + ni);
    }
  }

  // ---- Scheduling the cells ---------------------------------------------

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
      CellOutcome& r = outcomes[c];
      std::vector<Pair>& out = cell_pairs[c];
      out.clear();
      load_cell(w, engine_cell(c), partition->region(c));
      emit_cell(w, partition->region(c), out, r);
      if (consumer) consumer(c, out.data(), out.size());
    };
    if (!sink) {
      for_each_cell(cells, cell_task);
      return;
    }
    // Consumer (narrow phase) on cell k while the engine works on k+1...
    std::uint32_t next = 0;
    const auto tokens = static_cast<std::size_t>(2 * std::max(1, arena.max_concurrency()));
    tbb::parallel_pipeline(
        tokens,
        tbb::make_filter<void, std::uint32_t>(tbb::filter_mode::serial_in_order,
                                              [&](tbb::flow_control& fc) -> std::uint32_t {
                                                if (next >= cells) {
                                                  fc.stop();
                                                  return 0;
                                                }
                                                return next++;
                                              }) &
            tbb::make_filter<std::uint32_t, std::uint32_t>(tbb::filter_mode::parallel,
                                                           [&](std::uint32_t c) {
                                                             cell_task(c);
                                                             return c;
                                                           }) &
            tbb::make_filter<std::uint32_t, void>(tbb::filter_mode::serial_in_order, [&](std::uint32_t c) {
              sink(c, cell_pairs[c].data(), cell_pairs[c].size());
            }));
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

  // First pass: every cell through the engine, its pairs appended to the
  // worker's store; on a frame without an estimate, dense cells are only
  // counted (see kStoredPairsPerBox). `loaded`: the front lane already
  // loaded (and refreshed) the cell into this worker and gave it up.
  void first_pass(std::uint32_t c, bool loaded = false) {
    Worker& w = workers.local();
    CellOutcome& r = outcomes[c];
    const CellRegion& region = partition->region(c);
    if (!loaded) load_cell(w, engine_cell(c), region);
    r.stored = &w.stored;
    r.offset = w.stored.size();
    if (!w.direct || (!count_dense_cells && options.max_pairs)) {
      emit_cell(w, region, w.stored, r);  // (max_pairs: stores grow, see below)
      return;
    }
    if (!count_dense_cells && !w.store_full && store_within_budget(w, region, r)) return;
    const std::uint32_t n = w.cell.size();
    const std::size_t room = kStoredPairsPerBox * n + n + CellHitStream::kOutputSlack;
    fit_stage(w, std::max(room, stage_pairs(n)));
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
      drain_stage(w, count, w.stored);
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

  // ---- The lanes writing in place ------------------------------------------
  //
  // A steady frame's cells are claimed from both ends of the cell order: one
  // lane takes cells 0, 1, 2 ... and writes their pairs straight into the
  // front of the frame's list (the last frame's list, its pages warm),
  // where they stay. With two lanes the other one takes cells C-1, C-2 ...
  // and writes each into the back of the same list, below the cell after it
  // (the cell's pairs go through the worker's store, one cell at a time, so
  // the store is as large as the largest cell and stays in cache); the merge
  // then moves that block, one contiguous memmove, to end where this frame's
  // list ends. With more lanes, the lanes from the back store their cells
  // (several lanes finish cells out of claim order, so none can place them
  // one below the other), copied into place at the merge. The lanes meet
  // where their work balances, and the list is the same, in the same order:
  // cell c's pairs start at the sum of the pairs of cells before it in any
  // case. The two blocks share the old list's length (ListRoom); a lane that
  // finds no room left for a cell stores that cell and its later ones (the
  // middle cells, between the two blocks after the merge).

  bool front_lane_allowed() const {
    return direct_kernel && !count_dense_cells && !options.max_pairs &&
           !pairs.empty();
  }

  // Lanes of this frame when the front lane runs.
  int lane_count() const { return serial_engine_phase() ? 1 : std::max(1, arena.max_concurrency()); }

  void run_lanes(std::uint32_t cells) {
    std::atomic<std::uint64_t> ends{std::uint64_t{cells}};  // (next front cell << 32) | end of the back
    const std::size_t window = pairs.size();
    ListRoom room{window};
    ListFront front{pairs.data(), 0, &room};
    ListBack back{pairs.data() + window, 0, &room};
    const int lanes = lane_count();
    auto lane = [&](int k) {
      std::uint32_t c;
      if (k != 0) {
        bool in_place = lanes == 2 && window > 0;
        while (claim(ends, false, c)) {
          if (in_place) {
            in_place = back_cell(c, back);  // a cell that finds no room is stored
            continue;
          }
          first_pass(c);
        }
        return;
      }
      bool in_place = window > 0;
      while (claim(ends, true, c)) {
        // A cell the front lane gives up stays loaded (a cell is refreshed
        // once a frame, on its first trip through the engine).
        bool loaded = false;
        if (in_place) {
          in_place = front_cell(c, front);
          if (in_place) continue;
          loaded = true;
        }
        first_pass(c, loaded);
      }
    };
    if (lanes == 1)
      lane(0);
    else
      tbb::parallel_for(0, lanes, 1, lane);
    in_place_pairs = front.used;
    back_pairs = back.used;
    back_window = window;
  }

  // The next cell from the front (or the back); false when the lanes met.
  static bool claim(std::atomic<std::uint64_t>& ends, bool from_front, std::uint32_t& c) {
    std::uint64_t v = ends.load(std::memory_order_relaxed);
    while (true) {
      const auto lo = static_cast<std::uint32_t>(v >> 32), hi = static_cast<std::uint32_t>(v);
      if (lo >= hi) return false;
      const std::uint64_t next = from_front ? v + (std::uint64_t{1} << 32) : v - 1;
      if (ends.compare_exchange_weak(v, next, std::memory_order_relaxed)) {
        c = from_front ? lo : hi - 1;
        return true;
      }
    }
  }

  // Cell c's pairs straight into the list after the front lane's earlier
  // cells; false (nothing kept, the cell stays loaded) when they would pass
  // the room left.
  bool front_cell(std::uint32_t c, ListFront& front) {
    Worker& w = workers.local();
    CellOutcome& r = outcomes[c];
    const CellRegion& region = partition->region(c);
    load_cell(w, engine_cell(c), region);
    if (!emit_direct(w, region, front, r)) return false;
    r.in_place = true;
    return true;
  }

  // Cell c's pairs into the worker's store, then, room permitting, copied
  // into the list just below the back lane's earlier cells (and dropped from
  // the store); false when there was no room: the cell stays stored.
  bool back_cell(std::uint32_t c, ListBack& back) {
    Worker& w = workers.local();
    CellOutcome& r = outcomes[c];
    const CellRegion& region = partition->region(c);
    load_cell(w, engine_cell(c), region);
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

  // ---- A first frame written once --------------------------------------------
  //
  // A frame with no last count would count its dense cells, then run their
  // kernel again to write them (two kernel runs of the densest cells). With
  // two lanes and cells built this
  // frame (no refresh deferred to the engine, so loading a cell twice has no
  // side effect) the list is sized from a sample instead: every
  // kFirstFrameSampleStride-th cell counted, scaled by entries, plus a margin,
  // capped at the cells' n (n - 1) / 2. The lanes then write in place as on a
  // steady frame; an estimate too low leaves middle cells that find no room,
  // which are counted and written in the second pass (the fallback of every
  // frame), and one too high is cut to the frame's count at the merge (and
  // the list's storage replaced if it is more than twice what the frame
  // needs). False when this frame keeps the old way.
  bool first_frame_list(std::uint32_t cells) {
    if (refresh_in_engine || options.max_pairs || !direct_kernel || lane_count() != 2 ||
        cells < 2 * kFirstFrameSampleStride)
      return false;
    const std::uint32_t samples = cells / kFirstFrameSampleStride;
    std::atomic<std::uint64_t> sample_pairs{0}, sample_entries{0};
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, samples, 1), [&](const auto& r) {
      Worker& w = workers.local();
      std::uint64_t p = 0, e = 0;
      for (std::uint32_t k = r.begin(); k != r.end(); ++k) {
        const std::uint32_t c = k * kFirstFrameSampleStride + kFirstFrameSampleStride / 2;
        const CellRegion& region = partition->region(c);
        load_cell(w, partition->cell(c), region);
        p += w.direct->count_pairs(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, 0);
        e += w.cell.size();
      }
      sample_pairs.fetch_add(p, std::memory_order_relaxed);
      sample_entries.fetch_add(e, std::memory_order_relaxed);
    });
    std::uint64_t entries = 0, bound = 0;
    for (std::uint32_t c = 0; c < cells; ++c) {
      const std::uint64_t n = partition->cell(c).size();
      entries += n;
      bound += n * (n - (n > 0)) / 2;
    }
    if (sample_entries == 0 || sample_pairs == 0) return false;
    const double scaled = static_cast<double>(sample_pairs) * static_cast<double>(entries) /
                          static_cast<double>(sample_entries.load());
    auto estimate = static_cast<std::size_t>(scaled);
    estimate = static_cast<std::size_t>(std::min<std::uint64_t>(estimate + estimate / kFirstFrameMargin + kKeepCellPairs, bound));
    if (estimate == 0) return false;
    reserve_output(estimate);
    pairs.resize(estimate);
    return true;
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
    load_cell(w, partition->cell(c), partition->region(c));
    const std::uint32_t n = w.cell.size();
    fit_stage(w, stage_pairs(n));
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

  // Offsets of each cell's pairs in the frame's list, and the list sized.
  void size_output(std::uint32_t cells) {
    offsets.resize(std::size_t{cells} + 1);
    offsets[0] = 0;
    for (std::uint32_t c = 0; c < cells; ++c) offsets[c + 1] = offsets[c] + outcomes[c].pairs;
    const std::size_t total = offsets[cells];
    if (options.max_pairs && total > options.max_pairs)
      throw CapacityExceeded("frame has " + std::to_string(total) + " overlapping pairs, above max_pairs = " +
                             std::to_string(options.max_pairs));
    if (in_place_pairs || back_pairs) {
      // The lanes' cells are in place: keep them (growing copies), and move
      // the back lane's block to end where the list ends (before the stored
      // cells are copied in below it: growing, it leaves where they go).
      const std::size_t from = back_window - back_pairs, to = total - back_pairs;
      if (to <= from) {
        move_pairs(from, to, back_pairs);
        pairs.resize(total);
        // A first frame's estimate far too high: the list's storage follows the frame.
        if (estimated_list) retained::trim(pairs, kKeepPairs);
      } else {
        if (total > pairs.capacity()) pairs.reserve(total + total / 8);
        pairs.resize(total);
        move_pairs(from, to, back_pairs);
      }
    } else {
      reserve_output(total);
      pairs.resize(total);
    }
  }

  // Moves count pairs of the list from index `from` to index `to` (the
  // ranges may overlap), on all workers: the back lane's block is half of a
  // dense frame's list (~250 MB on clustered 1,000,000), moved by the change
  // in pair count, which is small on a steady frame. Overlapping by a
  // distance d, the block is cut into chunks of at least kMoveChunksPerShift
  // d: each chunk first sets aside the d pairs that land in its neighbour's
  // chunk (or the free gap) and moves the rest within itself; once all
  // chunks have, the set-aside pairs go to their place. A large distance
  // moves pieces of d one after another instead (each piece copied by all
  // workers: it lands where the previous piece was).
  void move_pairs(std::size_t from, std::size_t to, std::size_t count) {
    if (from == to || count == 0) return;
    Pair* base = pairs.data();
    const bool down = to < from;
    const std::size_t d = down ? from - to : to - from;
    const std::size_t chunks = static_cast<std::size_t>(kMoveChunksPerWorker * std::max(1, arena.max_concurrency()));
    if (count < kMoveParallelPairs || serial_engine_phase()) {
      std::memmove(base + to, base + from, count * sizeof(Pair));
      return;
    }
    auto copy = [&](std::size_t src, std::size_t dst, std::size_t n) {  // no overlap: in parallel
      tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t j) {
        const std::size_t lo = n * j / chunks, hi = n * (j + 1) / chunks;
        std::memcpy(base + dst + lo, base + src + lo, (hi - lo) * sizeof(Pair));
      });
    };
    if (d >= count) {
      copy(from, to, count);
      return;
    }
    if (d * kMoveChunksPerShift * chunks > count) {
      // Pieces of d, the one nearest the destination first.
      for (std::size_t done = 0; done < count; done += d) {
        const std::size_t n = std::min(d, count - done);
        const std::size_t src = down ? from + done : from + count - done - n;
        copy(src, down ? src - d : src + d, n);
      }
      return;
    }
    move_scratch.resize(chunks * d);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t j) {
      const std::size_t lo = from + count * j / chunks, hi = from + count * (j + 1) / chunks;
      Pair* aside = move_scratch.data() + j * d;
      if (down) {
        std::memcpy(aside, base + lo, d * sizeof(Pair));
        std::memmove(base + lo, base + lo + d, (hi - lo - d) * sizeof(Pair));
      } else {
        std::memcpy(aside, base + hi - d, d * sizeof(Pair));
        std::memmove(base + lo + d, base + lo, (hi - lo - d) * sizeof(Pair));
      }
    });
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t j) {
      const std::size_t lo = from + count * j / chunks, hi = from + count * (j + 1) / chunks;
      std::memcpy(down ? base + lo - d : base + hi, move_scratch.data() + j * d, d * sizeof(Pair));
    });
  }

  // Room for this frame's pairs. Growing reallocates without copying (the
  // old pairs are overwritten anyway) and leaves headroom, so a pair count
  // creeping up frame after frame does not reallocate every frame; large
  // lists ask for transparent huge pages (a pair-dense frame's list is
  // hundreds of megabytes: 512 times fewer page faults on the first frame).
  void reserve_output(std::size_t total) {
    retained::release(pairs, total, kKeepPairs);
    if (total <= pairs.capacity()) return;
    std::vector<Pair>().swap(pairs);
    pairs.reserve(list_capacity(total + total / 8));
    advise_huge_pages(pairs.data(), pairs.capacity() * sizeof(Pair));
    prefault(pairs.data(), total * sizeof(Pair));
  }

  // A fresh list's pages faulted in from every worker (prefault_pages): the
  // list's resize that follows would otherwise take every fault on one
  // thread.
  void prefault(void* data, std::size_t bytes) {
    if (bytes < kPrefaultBytes || serial_engine_phase()) return;
    prefault_pages(data, bytes);
  }

  // ---- The frame -----------------------------------------------------------

  void partition_frame(const BoxArray* boxes, const KdPartition* shared) {
    if (shared) {
      partition = shared;  // cells maintained elsewhere (the ray tracer's hierarchy)
      return;
    }
    partition = &own_partition;
    if (!boxes_checked) validate_boxes(*boxes);
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

  // Frames the partition would leave as one cell: no partition, no workers.
  bool is_one_cell_frame(const BoxArray* boxes) const { return boxes && boxes->size() <= cell_limit; }

  void run_one_cell(const BoxArray& boxes, const PairSink& sink, const PairSink& consumer) {
    if (!boxes_checked) validate_boxes_serial(boxes);
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
    estimated_list = false;
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
    } else {
      cell_pairs.clear();
      estimated_list = count_dense_cells && first_frame_list(cells);
      if (estimated_list) {
        count_dense_cells = false;
      } else {
        // The last frame's list is dead now; one much larger than this frame
        // needs is released rather than kept as room.
        retained::release(pairs, last_frame_pairs, kKeepPairs);
      }
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
  }

  void sort_output() {
    if (options.sorted) parallel_sort_pairs(pairs, sort_scratch, arena);  // scratch: the list + a small tail
    retained::release(sort_scratch, options.sorted ? pairs.size() : 0, kKeepPairs);
    retained::release(move_scratch, move_scratch.size(), kKeepPairs);
    move_scratch.clear();
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

  void run(const BoxArray* boxes, const KdPartition* shared, const PairSink& sink, const PairSink& consumer) {
    running_pairs = 0;
    const auto t0 = SteadyClock::now();
    double partition_ms = 0, engine_ms = 0, merge_ms = 0;
    const bool one_cell = !shared && is_one_cell_frame(boxes);
    if (one_cell) {
      const auto t_engine = SteadyClock::now();
      run_one_cell(*boxes, sink, consumer);
      engine_ms = ms_since(t_engine);
    } else {
      const auto t_partition = SteadyClock::now();
      partition_frame(boxes, shared);
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
    if (one_cell) {
      const auto n = static_cast<std::uint32_t>(objects);
      stats.cells = 1;
      stats.min_cell = stats.median_cell = stats.max_cell = n;
      stats.duplication = 1.0;
      stats.oversized_cells = 0;
      stats.rebuilt = false;
      stats.rebuilt_subtrees = 0;
      stats.rebuilt_entries = 0;
      stats.splits = stats.merges = 0;
      return;
    }
    const PartitionStats& ps = partition->stats();
    stats.cells = ps.cells;
    stats.min_cell = ps.min_cell;
    stats.median_cell = ps.median_cell;
    stats.max_cell = ps.max_cell;
    stats.duplication = ps.duplication;
    stats.oversized_cells = ps.oversized_cells;
    stats.rebuilt = ps.rebuilt;
    stats.rebuilt_subtrees = ps.rebuilt_subtrees;
    stats.rebuilt_entries = ps.rebuilt_entries;
    stats.splits = ps.splits;
    stats.merges = ps.merges;
  }
};

HybridBroadPhase::HybridBroadPhase(const BroadPhaseOptions& options) : impl_(std::make_unique<Impl>(options)) {}
HybridBroadPhase::~HybridBroadPhase() = default;
HybridBroadPhase::HybridBroadPhase(HybridBroadPhase&&) noexcept = default;
HybridBroadPhase& HybridBroadPhase::operator=(HybridBroadPhase&&) noexcept = default;

const std::vector<Pair>& HybridBroadPhase::update(const BoxArray& boxes, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  // Small frames stay on the calling thread: entering the arena would wake
  // its workers for nothing.
  if (boxes.size() <= impl_->cell_limit)
    impl_->run(&boxes, nullptr, sink, parallel_consumer);
  else
    impl_->arena.execute([&] { impl_->run(&boxes, nullptr, sink, parallel_consumer); });
  return impl_->pairs;
}

const std::vector<Pair>& HybridBroadPhase::update(const KdPartition& cells, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->arena.execute([&] { impl_->run(nullptr, &cells, sink, parallel_consumer); });
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

const std::vector<Pair>& detail::HybridAccess::update_checked(HybridBroadPhase& hybrid, const BoxArray& boxes) {
  HybridBroadPhase::Impl& impl = *hybrid.impl_;
  impl.boxes_checked = true;
  try {
    hybrid.update(boxes);
  } catch (...) {
    impl.boxes_checked = false;
    throw;
  }
  impl.boxes_checked = false;
  return impl.pairs;
}

void detail::HybridAccess::swap_pairs(HybridBroadPhase& hybrid, std::vector<Pair>& other) {
  hybrid.impl_->pairs.swap(other);
}

}  // namespace hbp
