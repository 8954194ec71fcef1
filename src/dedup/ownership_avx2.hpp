#pragma once
// The ownership rule (ownership.hpp) on 8 lanes, for the AVX2 kernels: the
// row box's minimum corner against 8 candidates' at once. Include only from
// files compiled for AVX2 (engines/box_kernels_avx2.cpp).
#include <immintrin.h>

#include "hbp/cell_region.hpp"

namespace hbp::dedup::avx2 {

// A cell's region broadcast to every lane, loaded once per kernel call.
struct RegionLanes {
  __m256 lo[3], hi[3];
};

inline RegionLanes load_region(const CellRegion& r) {
  RegionLanes v;
  for (int k = 0; k < 3; ++k) {
    v.lo[k] = _mm256_set1_ps(r.lo[k]);
    v.hi[k] = _mm256_set1_ps(r.hi[k]);
  }
  return v;
}

// All-ones lanes where the region holds the point (px, py, pz): lo <= p < hi.
inline __m256 contains(const RegionLanes& r, __m256 px, __m256 py, __m256 pz) {
  __m256 m = _mm256_and_ps(_mm256_cmp_ps(px, r.lo[0], _CMP_GE_OQ), _mm256_cmp_ps(px, r.hi[0], _CMP_LT_OQ));
  m = _mm256_and_ps(m, _mm256_and_ps(_mm256_cmp_ps(py, r.lo[1], _CMP_GE_OQ), _mm256_cmp_ps(py, r.hi[1], _CMP_LT_OQ)));
  return _mm256_and_ps(m, _mm256_and_ps(_mm256_cmp_ps(pz, r.lo[2], _CMP_GE_OQ), _mm256_cmp_ps(pz, r.hi[2], _CMP_LT_OQ)));
}

// Lanes the region owns: the row box's minimum corner (lx, ly, lz, broadcast)
// against the candidates' (cx, cy, cz); p = max per axis.
inline __m256 owns(const RegionLanes& r, __m256 lx, __m256 ly, __m256 lz, __m256 cx, __m256 cy, __m256 cz) {
  return contains(r, _mm256_max_ps(cx, lx), _mm256_max_ps(cy, ly), _mm256_max_ps(cz, lz));
}

// The same when the candidates follow the row in min-x order (the sweep):
// their min x is already the larger, so p's x is theirs.
inline __m256 owns_sorted_x(const RegionLanes& r, __m256 ly, __m256 lz, __m256 cx, __m256 cy, __m256 cz) {
  return contains(r, cx, _mm256_max_ps(cy, ly), _mm256_max_ps(cz, lz));
}

}  // namespace hbp::dedup::avx2
