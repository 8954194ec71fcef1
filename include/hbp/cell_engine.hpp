// SPDX-License-Identifier: MIT
#pragma once
// A cell engine finds every overlapping pair among the boxes of one cell: the
// "accelerator" stage of the hybrid system. Implementations: the software SIMD
// engine, the cycle-accurate hardware models, the Verilated RTL.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/pair.hpp"

namespace hbp {

struct CellRun {
  std::uint64_t cycles = 0;  // modelled accelerator cycles (0 for software)
};

// A batch of cells for CellEngine::find_owned_pairs_batch: cell k is boxes
// [starts[k], starts[k + 1]) of `boxes`, sorted by increasing min x, and
// owns the pairs whose ownership point lies in regions[k].
struct CellBatch {
  const BoxArray* boxes = nullptr;
  std::span<const std::uint32_t> starts;  // cells() + 1 entries, starts[0] == 0
  std::span<const CellRegion> regions;    // cells() entries
  std::uint32_t cells() const { return static_cast<std::uint32_t>(regions.size()); }
};

// What find_owned_pairs_batch reports for one cell of the batch.
struct CellBatchOutcome {
  std::size_t end = 0;  // out.size() after the cell's pairs
  CellRun run;
};

// The streaming door of a cell engine. An engine whose kernel writes a
// cell's hits, with the caller's ids, into a bounded stage row by row (the
// software kernels) offers it through CellEngine::hit_stream(); the hybrid
// system then moves hits from the stage straight into the frame's list (no
// list of local indices in between) and can count a dense cell before it
// writes it. Every other engine is driven through find_owned_pairs.
class CellHitStream {
 public:
  // Spare entries emit_hits may write past the last hit it reports, and the
  // padding owner_codes adds.
  static constexpr std::size_t kOutputSlack = 16;
  // A stage of min_output(n) entries always lets emit_hits make progress.
  static constexpr std::size_t min_output(std::uint32_t n) { return 2 * std::size_t{n} + kOutputSlack; }

  // Each box's owner code against `region` (the ownership rule split per
  // box, dedup/ownership.hpp), padded: codes.size() becomes cell.size() +
  // kOutputSlack.
  virtual void owner_codes(const BoxArray& cell, const CellRegion& region, std::vector<std::uint32_t>& codes) const = 0;
  // `cell` is sorted by min x, ids[k] is the id reported for box k and
  // owner_codes[k] its owner code against `region`, both readable up to
  // cell.size() + kOutputSlack. Runs rows [row, n) and writes hit k as the
  // two ids (first[count + k], second[count + k]), not yet ordered; returns
  // the row it stopped at: n when done, earlier when fewer than
  // 2 (n - row) + kOutputSlack of `capacity` entries were free (drain with
  // write_pairs() and resume from there). The hits come in the same order
  // however often the caller drains.
  virtual std::uint32_t emit_hits(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                                  const CellRegion& region, std::uint32_t row, std::uint32_t* first,
                                  std::uint32_t* second, std::size_t capacity, std::size_t& count) const = 0;
  // The hits rows [row, n) would emit, counted without storing them.
  virtual std::uint64_t count_pairs(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                                    const CellRegion& region, std::uint32_t row) const = 0;
  // Hits as canonical pairs (min id, max id), written to out[0 .. count).
  static void write_pairs(const std::uint32_t* first, const std::uint32_t* second, std::size_t count, Pair* out);

 protected:
  ~CellHitStream() = default;
};

class CellEngine {
 public:
  virtual ~CellEngine() = default;
  virtual std::string name() const = 0;
  // Most boxes one call accepts (hardware: the buffer's capacity). The
  // partition never sends more; larger cells are processed in tiles.
  virtual std::uint32_t capacity() const = 0;
  // Cell limit to use when the user does not choose one.
  virtual std::uint32_t default_cell_limit() const = 0;
  // Weight of the x spread when the partition picks a split axis. A sweep on
  // x wants cells longer in x (fewer candidates per box): < 1. All-pairs
  // engines do not care about cell shape: 1.
  virtual float x_split_weight() const { return 1.0f; }
  // Clock for converting cycles to modelled time (0 for software engines).
  virtual double clock_hz() const { return 0.0; }
  // Appends the pairs (i < j, local indices into `cell`) of every overlapping
  // pair of boxes in `cell`. Order: engine-specific but deterministic.
  // Throws CapacityExceeded when cell.size() > capacity().
  virtual CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) = 0;
  // The hybrid system's call: like find_pairs, but keeps only the pairs whose
  // ownership point max(min_i, min_j) lies in `region` (de-duplication), and
  // `cell` is sorted by increasing min x. Software engines fuse the filter
  // into their kernel; the default filters find_pairs' output in place.
  virtual CellRun find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out);
  // The hybrid system's call for the cells of a frame taken together (an
  // accelerator behind a bus wants a few large transfers and launches, not
  // a round trip per cell): cell k's owned pairs, indices local to the cell
  // as find_owned_pairs gives them, appended to `out` in cell order, and
  // outcomes[k] set (outcomes.size() == batch.cells()). Every cell holds at
  // most capacity() boxes. The default runs find_owned_pairs cell by cell.
  virtual void find_owned_pairs_batch(const CellBatch& batch, std::vector<Pair>& out,
                                      std::span<CellBatchOutcome> outcomes);
  // Cycles the engine would spend on a cell of n boxes, without running it
  // (analytic; equals what find_pairs reports).
  virtual std::uint64_t cycles_for(std::uint32_t n) const { (void)n; return 0; }
  // Engines are used by one thread at a time; each worker gets a clone.
  virtual std::unique_ptr<CellEngine> clone() const = 0;
  // The engine's streaming door, or nullptr when it has none (see
  // CellHitStream); the stream belongs to this engine (same thread, same
  // lifetime).
  virtual const CellHitStream* hit_stream() const { return nullptr; }

  // Most pairs one call may append before it stops with CapacityExceeded
  // (the hybrid system passes BroadPhaseOptions::max_pairs), so a pair
  // explosion inside one cell never exhausts memory.
  void set_pair_limit(std::uint64_t limit) { pair_limit_ = limit; }
  std::uint64_t pair_limit() const { return pair_limit_; }

 protected:
  std::uint64_t pair_limit_ = ~std::uint64_t{0};

 private:
  BoxArray batch_cell_;  // the default batch's current cell
};

// Engines by name. The core library has "sw" (software SIMD sweep, the
// default), "sw-allpairs" (software SIMD all-pairs) and "brute" (scalar
// all-pairs). Rooms above the core plug theirs in through
// register_cell_engine(): the hardware models (hbp::hw::register_cell_engines():
// "ae", "mo" = the software sweep finds the pairs, the cycles are charged
// analytically; "ae-sim", "mo-sim" = every cycle of the model simulated) and
// the Verilated RTL (hbp::rtl::register_rtl_engines(): "rtl-ae", "rtl-mo").
// make_cell_engine throws InvalidInput naming an unknown engine and listing
// the known ones.
std::unique_ptr<CellEngine> make_cell_engine(const std::string& name);
// Every known name, sorted.
std::vector<std::string> cell_engine_names();
// What the engine named `name` does (one line); InvalidInput when unknown.
std::string cell_engine_description(const std::string& name);

// Engines living outside the core library register themselves by name before
// use. A name is taken once: registering a name already taken by a built-in
// engine or by a different factory throws InvalidInput naming it; registering
// the same name with the same factory again is a no-op (so registration
// functions are idempotent).
using CellEngineFactory = std::unique_ptr<CellEngine> (*)();
void register_cell_engine(const std::string& name, CellEngineFactory factory, const std::string& description = "");

}  // namespace hbp
