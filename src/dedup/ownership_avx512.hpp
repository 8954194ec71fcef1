#pragma once
// The ownership rule (ownership.hpp) on 16 lanes, for the AVX-512 kernels:
// the row box's minimum corner against 16 candidates' at once. Include only
// from files compiled for AVX-512 (engines/box_kernels_avx512.cpp).
#include <immintrin.h>

#include "hbp/cell_region.hpp"

namespace hbp::dedup::avx512 {

// A cell's region broadcast to every lane, loaded once per kernel call.
struct RegionLanes {
  __m512 lo[3], hi[3];
};

inline RegionLanes load_region(const CellRegion& r) {
  RegionLanes v;
  for (int k = 0; k < 3; ++k) {
    v.lo[k] = _mm512_set1_ps(r.lo[k]);
    v.hi[k] = _mm512_set1_ps(r.hi[k]);
  }
  return v;
}

// Lanes where the region holds the point (px, py, pz): lo <= p < hi, as a
// chain of masked compares.
inline __mmask16 contains(const RegionLanes& r, __m512 px, __m512 py, __m512 pz) {
  __mmask16 m = _mm512_cmp_ps_mask(px, r.lo[0], _CMP_GE_OQ);
  m = _mm512_mask_cmp_ps_mask(m, px, r.hi[0], _CMP_LT_OQ);
  m = _mm512_mask_cmp_ps_mask(m, py, r.lo[1], _CMP_GE_OQ);
  m = _mm512_mask_cmp_ps_mask(m, py, r.hi[1], _CMP_LT_OQ);
  m = _mm512_mask_cmp_ps_mask(m, pz, r.lo[2], _CMP_GE_OQ);
  return _mm512_mask_cmp_ps_mask(m, pz, r.hi[2], _CMP_LT_OQ);
}

// Lanes the region owns: the row box's minimum corner (lx, ly, lz, broadcast)
// against the candidates' (cx, cy, cz); p = max per axis.
inline __mmask16 owns(const RegionLanes& r, __m512 lx, __m512 ly, __m512 lz, __m512 cx, __m512 cy, __m512 cz) {
  return contains(r, _mm512_max_ps(cx, lx), _mm512_max_ps(cy, ly), _mm512_max_ps(cz, lz));
}

// The same when the candidates follow the row in min-x order (the sweep):
// their min x is already the larger, so p's x is theirs.
inline __mmask16 owns_sorted_x(const RegionLanes& r, __m512 ly, __m512 lz, __m512 cx, __m512 cy, __m512 cz) {
  return contains(r, cx, _mm512_max_ps(cy, ly), _mm512_max_ps(cz, lz));
}

}  // namespace hbp::dedup::avx512
