// SPDX-License-Identifier: MIT
#pragma once
// Tiling: how an engine with a capacity (hardware: its buffer) takes a cell
// with more objects than that (identical or nested boxes the partition
// cannot split). Every pair of blocks of capacity/2 goes through the engine;
// block i's own pairs are kept from the run (i, i+1), the last block's from
// (k-2, k-1), so each pair comes out once. Two consecutive ranges of the
// min-x order are in min-x order together, as find_owned_pairs requires.
#include <algorithm>
#include <cstdint>

#include "hbp/box_array.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/pair.hpp"
#include "pipeline/cell_worker.hpp"
#include "pipeline/pair_outputs.hpp"

namespace hbp::detail {

// Blocks [oi, oi + ni) and [oj, oj + nj) of the loaded cell into w.tile.
inline void copy_tile(Worker& w, std::uint32_t oi, std::uint32_t ni, std::uint32_t oj, std::uint32_t nj) {
  const BoxArray& src = w.cell.boxes();
  w.tile.resize(ni + nj);
  for (int k = 0; k < 3; ++k) {
    std::copy_n(src.min(k) + oi, ni, w.tile.min(k));
    std::copy_n(src.min(k) + oj, nj, w.tile.min(k) + ni);
    std::copy_n(src.max(k) + oi, ni, w.tile.max(k));
    std::copy_n(src.max(k) + oj, nj, w.tile.max(k) + ni);
  }
}

// Appends the loaded cell's owned pairs (global ids, canonical) to out;
// charge(n) is told of every n pairs appended (the frame's max_pairs).
template <class Out, class Charge>
void emit_tiled(Worker& w, const CellRegion& region, Out& out, CellOutcome& r, Charge&& charge) {
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

}  // namespace hbp::detail
