// SPDX-License-Identifier: MIT
#pragma once
// What one worker of the hybrid system keeps from cell to cell and frame to
// frame (its engine clone, the cell being processed, the stage the kernel
// writes into, its store of pairs), and what one cell produced this frame.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_engine.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/kd_partition.hpp"
#include "hbp/pair.hpp"
#include "partition/raw_buffer.hpp"
#include "pipeline/ordered_cell.hpp"
#include "support/retained.hpp"

namespace hbp::detail {

// The kernel's output lands in a cache-resident stage before it moves on
// (4 K pairs: first + second fit L1 beside the cell; 16 K cost ~4 % more
// CPU on clustered 1,000,000, see docs/hybrid-system.md "Pair-dense frames").
inline constexpr std::size_t kStagePairs = 1 << 12;
// Pair buffers kept from frame to frame follow the retained rule
// (support/retained.hpp) with its default slack; a list kept per cell
// (there are thousands) with a smaller one.
inline constexpr std::size_t kKeepPairs = retained::kSlack<Pair>;
inline constexpr std::size_t kKeepCellPairs = 1 << 10;

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
  // Engines without the streaming door take cells in batches
  // (CellEngine::find_owned_pairs_batch): the cells back to back, each in
  // min-x order, their ids, and which cell of the frame each one is.
  struct Batch {
    BoxArray boxes;
    std::vector<std::uint32_t> ids, starts, cells;
    std::vector<CellRegion> regions;
    std::vector<CellBatchOutcome> outcomes;
  } batch;
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
  bool in_place = false;  // written straight into the frame's list by a lane
};

// The cell in min-x order, and for a streaming engine its owner codes.
inline void load_cell(Worker& w, std::span<const CellEntry> entries, const CellRegion& region) {
  w.cell.load(entries);
  if (w.direct) w.direct->owner_codes(w.cell.boxes(), region, w.codes);
}

// A stage of this many entries lets the kernel run a cell of n boxes.
inline std::size_t stage_pairs(std::uint32_t n) {
  return std::max(kStagePairs, 2 * (std::size_t{n} + CellHitStream::kOutputSlack));
}

inline void fit_stage(Worker& w, std::size_t hits) {
  if (w.first.size() < hits || retained::oversized(w.first.size(), hits, kKeepPairs)) {
    w.first.assign(hits, 0);
    w.second.assign(hits, 0);
  }
}

}  // namespace hbp::detail
