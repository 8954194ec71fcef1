// GCC 12 reports its own _mm512_undefined_ps() inside _mm512_max_ps as
// "may be used uninitialized" (a false positive in the intrinsic header).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include "engines/box_kernels.hpp"

namespace hbp::kernels {

namespace {

struct RegionVec {
  __m512 lo[3], hi[3];
};

inline RegionVec load_region(const CellRegion& r) {
  RegionVec v;
  for (int k = 0; k < 3; ++k) {
    v.lo[k] = _mm512_set1_ps(r.lo[k]);
    v.hi[k] = _mm512_set1_ps(r.hi[k]);
  }
  return v;
}

inline __mmask16 owned(const RegionVec& r, __m512 px, __m512 py, __m512 pz) {
  __mmask16 m = _mm512_cmp_ps_mask(px, r.lo[0], _CMP_GE_OQ);
  m = _mm512_mask_cmp_ps_mask(m, px, r.hi[0], _CMP_LT_OQ);
  m = _mm512_mask_cmp_ps_mask(m, py, r.lo[1], _CMP_GE_OQ);
  m = _mm512_mask_cmp_ps_mask(m, py, r.hi[1], _CMP_LT_OQ);
  m = _mm512_mask_cmp_ps_mask(m, pz, r.lo[2], _CMP_GE_OQ);
  return _mm512_mask_cmp_ps_mask(m, pz, r.hi[2], _CMP_LT_OQ);
}

// Branch-free: compress the hit lanes' j into the front of a vector and
// store all 16 lanes (the output keeps kOutputSlack spare entries); a branch
// on "any hit" mispredicts too often to pay.
inline void emit(std::uint32_t i, std::uint32_t j, __mmask16 mask, KernelOutput& out) {
  const __m512i lanes = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  const __m512i js = _mm512_maskz_compress_epi32(mask, _mm512_add_epi32(_mm512_set1_epi32(static_cast<int>(j)), lanes));
  _mm512_storeu_si512(out.second + out.count, js);
  _mm512_storeu_si512(out.first + out.count, _mm512_set1_epi32(static_cast<int>(i)));
  out.count += static_cast<std::size_t>(__builtin_popcount(mask));
}

}  // namespace

std::uint32_t sweep_avx512(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
  const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
  const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
  const RegionVec rv = load_region(in.region);
  for (std::uint32_t i = row; i < in.n; ++i) {
    if (out.capacity - out.count < std::size_t{in.n - i} + kOutputSlack) return i;
    const __m512 bx = _mm512_set1_ps(maxx[i]);
    const __m512 ly = _mm512_set1_ps(miny[i]), hy = _mm512_set1_ps(maxy[i]);
    const __m512 lz = _mm512_set1_ps(minz[i]), hz = _mm512_set1_ps(maxz[i]);
    for (std::uint32_t j = i + 1;; j += 16) {
      const __m512 vminx = _mm512_loadu_ps(minx + j);
      const __m512 vminy = _mm512_loadu_ps(miny + j), vminz = _mm512_loadu_ps(minz + j);
      // Padding boxes have min = +inf, so the scan always ends inside the lane.
      const __mmask16 mx = _mm512_cmp_ps_mask(vminx, bx, _CMP_LE_OQ);
      // Independent compares joined by kand: a short dependency chain.
      const __mmask16 my = _mm512_cmp_ps_mask(_mm512_loadu_ps(maxy + j), ly, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(vminy, hy, _CMP_LE_OQ);
      const __mmask16 mz = _mm512_cmp_ps_mask(_mm512_loadu_ps(maxz + j), lz, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(vminz, hz, _CMP_LE_OQ);
      const __mmask16 m = mx & my & mz & owned(rv, vminx, _mm512_max_ps(vminy, ly), _mm512_max_ps(vminz, lz));
      emit(i, j, m, out);
      if (mx != 0xFFFF) break;
    }
  }
  return in.n;
}

std::uint32_t allpairs_avx512(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
  const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
  const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
  const RegionVec rv = load_region(in.region);
  for (std::uint32_t i = row; i < in.n; ++i) {
    if (out.capacity - out.count < std::size_t{in.n - i} + kOutputSlack) return i;
    const __m512 lx = _mm512_set1_ps(minx[i]), hx = _mm512_set1_ps(maxx[i]);
    const __m512 ly = _mm512_set1_ps(miny[i]), hy = _mm512_set1_ps(maxy[i]);
    const __m512 lz = _mm512_set1_ps(minz[i]), hz = _mm512_set1_ps(maxz[i]);
    for (std::uint32_t j = i + 1; j < in.n; j += 16) {
      const __m512 vminx = _mm512_loadu_ps(minx + j), vminy = _mm512_loadu_ps(miny + j),
                   vminz = _mm512_loadu_ps(minz + j);
      __mmask16 m = _mm512_cmp_ps_mask(_mm512_loadu_ps(maxx + j), lx, _CMP_GE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, vminx, hx, _CMP_LE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(maxy + j), ly, _CMP_GE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, vminy, hy, _CMP_LE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(maxz + j), lz, _CMP_GE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, vminz, hz, _CMP_LE_OQ);
      if (m) {
        m &= owned(rv, _mm512_max_ps(vminx, lx), _mm512_max_ps(vminy, ly), _mm512_max_ps(vminz, lz));
        emit(i, j, m, out);
      }
    }
  }
  return in.n;
}

}  // namespace hbp::kernels
