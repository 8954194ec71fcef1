// SPDX-License-Identifier: MIT
#pragma once
// The lanes: a steady frame's cells claimed from both ends of the cell
// order. Lane 0 takes cells 0, 1, 2 ... and writes their pairs straight into
// the front of the frame's list (the last frame's list, its pages warm),
// where they stay. With two lanes the other one takes cells C-1, C-2 ... and
// writes each into the back of the same list, below the cell after it; the
// merge then moves that block to end where this frame's list ends. With more
// lanes, the lanes from the back store their cells (several lanes finish
// cells out of claim order, so none can place them one below the other),
// copied into place at the merge. The lanes meet where their work balances,
// and the list is the same, in the same order: cell c's pairs start at the
// sum of the pairs of cells before it in any case. A lane that finds no room
// left for a cell stores that cell and its later ones (the middle cells,
// between the two blocks after the merge).
#include <atomic>
#include <cstdint>

#include "support/parallel_for.hpp"

namespace hbp::detail {

// One 64-bit word, (next front cell << 32) | end of the back, so a claim
// from either end is one compare-exchange and no cell is taken twice.
class CellClaims {
 public:
  explicit CellClaims(std::uint32_t cells) : ends_(std::uint64_t{cells}) {}

  // The next cell from the front (or the back); false when the lanes met.
  bool claim(bool from_front, std::uint32_t& c) {
    std::uint64_t v = ends_.load(std::memory_order_relaxed);
    while (true) {
      const auto lo = static_cast<std::uint32_t>(v >> 32), hi = static_cast<std::uint32_t>(v);
      if (lo >= hi) return false;
      const std::uint64_t next = from_front ? v + (std::uint64_t{1} << 32) : v - 1;
      if (ends_.compare_exchange_weak(v, next, std::memory_order_relaxed)) {
        c = from_front ? lo : hi - 1;
        return true;
      }
    }
  }

 private:
  std::atomic<std::uint64_t> ends_;
};

// Runs cells [0, cells) on `lanes` lanes (1: on the calling thread). With
// room in the list (in_place), the front lane calls front_cell(c) until it
// returns false (no room: the cell stays loaded) and the back lane, when
// there are exactly two lanes, back_cell(c) until it does (the cell stays
// stored); every other cell goes to store_cell(c, loaded).
template <class Front, class Back, class Store>
void run_lanes(std::uint32_t cells, int lanes, bool in_place, Front&& front_cell, Back&& back_cell,
               Store&& store_cell) {
  CellClaims claims(cells);
  auto lane = [&](int k) {
    std::uint32_t c;
    if (k != 0) {
      bool back_in_place = lanes == 2 && in_place;
      while (claims.claim(false, c)) {
        if (back_in_place) {
          back_in_place = back_cell(c);  // a cell that finds no room is stored
          continue;
        }
        store_cell(c, false);
      }
      return;
    }
    bool front_in_place = in_place;
    while (claims.claim(true, c)) {
      // A cell the front lane gives up stays loaded (a cell is refreshed
      // once a frame, on its first trip through the engine).
      bool loaded = false;
      if (front_in_place) {
        front_in_place = front_cell(c);
        if (front_in_place) continue;
        loaded = true;
      }
      store_cell(c, loaded);
    }
  };
  if (lanes == 1)
    lane(0);
  else
    parallel_for_each(static_cast<std::size_t>(lanes), [&](std::size_t k) { lane(static_cast<int>(k)); });
}

}  // namespace hbp::detail
