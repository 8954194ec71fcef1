// SPDX-License-Identifier: MIT
#pragma once
// One loaded cell through its worker's engine, its owned pairs (global ids,
// canonical) appended to any pair output (pair_outputs.hpp). Three ways in,
// one per kind of engine: the streaming door (CellHitStream) drains its
// stage into the output; any other engine returns local indices, mapped to
// ids; a cell past the engine's capacity is tiled (tiled_cells.hpp).
// charge(n) is told of every n pairs appended (the frame's max_pairs).
#include <cstddef>
#include <cstdint>
#include <limits>

#include "hbp/cell_region.hpp"
#include "hbp/pair.hpp"
#include "pipeline/cell_worker.hpp"
#include "pipeline/pair_outputs.hpp"
#include "pipeline/tiled_cells.hpp"

namespace hbp::detail {

// A streaming engine writes global ids into the stage; the stage drains
// into out whenever it fills. Should out grow past `limit` pairs (a store's
// touch budget) or past its room (a list's front), what the cell appended
// is taken back and false returned.
template <class Out, class Charge>
bool emit_direct(Worker& w, const CellRegion& region, Out& out, CellOutcome& r, Charge&& charge,
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
template <class Out, class Charge>
void emit_whole(Worker& w, const CellRegion& region, Out& out, CellOutcome& r, Charge&& charge) {
  w.local.clear();
  r.cycles += w.engine->find_owned_pairs(w.cell.boxes(), region, w.local).cycles;
  charge(w.local.size());
  const std::uint32_t* ids = w.cell.ids();
  for (const Pair& p : w.local) append(out, make_pair(ids[p.a], ids[p.b]));
  r.pairs += w.local.size();
  r.candidates += w.local.size();
}

template <class Out, class Charge>
void emit_cell(Worker& w, const CellRegion& region, Out& out, CellOutcome& r, Charge&& charge) {
  if (w.direct)
    emit_direct(w, region, out, r, charge);
  else if (w.cell.size() <= w.engine->capacity())
    emit_whole(w, region, out, r, charge);
  else
    emit_tiled(w, region, out, r, charge);
}

}  // namespace hbp::detail
