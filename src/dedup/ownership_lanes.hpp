// SPDX-License-Identifier: MIT
#pragma once
// The ownership rule (ownership.hpp) on a vector of candidates, written once
// for every instruction set: the row box's minimum corner against the
// candidates' lane by lane, p = max per axis, owned where lo <= p < hi on
// all three axes. An ISA supplies its lanes as `L` (ownership_avx2.hpp,
// ownership_avx512.hpp):
//   L::Vec, L::Mask                     a float vector and a lane mask
//   L::broadcast(float) -> Vec
//   L::max(Vec, Vec) -> Vec
//   L::within(Vec p, Vec lo, Vec hi) -> Mask           lanes with lo <= p < hi
//   L::within(Mask m, Vec p, Vec lo, Vec hi) -> Mask   m's lanes that also are
// Everything is in an anonymous namespace: each ISA's kernel file keeps its
// own copy, compiled with its own flags (see engines/box_kernels.hpp).
#include "hbp/cell_region.hpp"

namespace hbp::dedup {
namespace {

// A cell's region broadcast to every lane, loaded once per kernel call.
template <class L>
struct RegionLanes {
  typename L::Vec lo[3], hi[3];
};

template <class L>
inline RegionLanes<L> load_region(const CellRegion& r) {
  RegionLanes<L> v;
  for (int k = 0; k < 3; ++k) {
    v.lo[k] = L::broadcast(r.lo[k]);
    v.hi[k] = L::broadcast(r.hi[k]);
  }
  return v;
}

// Lanes where the region holds the point (px, py, pz).
template <class L, class V = typename L::Vec>
inline typename L::Mask contains(const RegionLanes<L>& r, V px, V py, V pz) {
  return L::within(L::within(L::within(px, r.lo[0], r.hi[0]), py, r.lo[1], r.hi[1]), pz, r.lo[2], r.hi[2]);
}

// Lanes the region owns: the row box's minimum corner (lx, ly, lz, broadcast)
// against the candidates' (cx, cy, cz).
template <class L, class V = typename L::Vec>
inline typename L::Mask owns(const RegionLanes<L>& r, V lx, V ly, V lz, V cx, V cy, V cz) {
  return contains(r, L::max(cx, lx), L::max(cy, ly), L::max(cz, lz));
}

// The same when the candidates follow the row in min-x order (the sweep):
// their min x is already the larger, so p's x is theirs.
template <class L, class V = typename L::Vec>
inline typename L::Mask owns_sorted_x(const RegionLanes<L>& r, V ly, V lz, V cx, V cy, V cz) {
  return contains(r, cx, L::max(cy, ly), L::max(cz, lz));
}

}  // namespace
}  // namespace hbp::dedup
