// SPDX-License-Identifier: MIT
#include <immintrin.h>

#include "dedup/ownership_avx2.hpp"
#include "engines/box_kernel_rows.hpp"
#include "engines/box_kernels.hpp"

namespace hbp::kernels {

namespace {

using Lanes = dedup::Avx2Lanes;
using RegionVec = dedup::RegionLanes<Lanes>;

// Where a row's hits go: stored (row id, candidate id), or only counted.
struct Store {
  std::uint32_t* first;
  std::uint32_t* second;
  std::size_t count;
  void emit(std::uint32_t id_i, const std::uint32_t* ids_j, unsigned mask) {
    while (mask) {
      first[count] = id_i;
      second[count] = ids_j[__builtin_ctz(mask)];
      ++count;
      mask &= mask - 1;
    }
  }
};

struct Count {
  std::uint64_t count = 0;
  void emit(std::uint32_t, const std::uint32_t*, unsigned mask) { count += static_cast<std::uint64_t>(__builtin_popcount(mask)); }
};

// This ISA's rows, for KernelsOf (box_kernel_rows.hpp).
struct Rows {
  static RegionVec region(const CellRegion& r) { return dedup::load_region<Lanes>(r); }

  template <class Out>
  static void sweep_row(const KernelInput& in, const RegionVec& rv, std::uint32_t i, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxy = in.max[1], *maxz = in.max[2];
    const __m256 bx = _mm256_set1_ps(in.max[0][i]);
    const __m256 ly = _mm256_set1_ps(miny[i]), hy = _mm256_set1_ps(maxy[i]);
    const __m256 lz = _mm256_set1_ps(minz[i]), hz = _mm256_set1_ps(maxz[i]);
    for (std::uint32_t j = i + 1;; j += 8) {
      const __m256 vminx = _mm256_loadu_ps(minx + j);
      const __m256 cx = _mm256_cmp_ps(vminx, bx, _CMP_LE_OQ);
      const unsigned mx = static_cast<unsigned>(_mm256_movemask_ps(cx));
      if (!mx) break;
      const __m256 vminy = _mm256_loadu_ps(miny + j), vminz = _mm256_loadu_ps(minz + j);
      __m256 c = _mm256_and_ps(cx, _mm256_cmp_ps(_mm256_loadu_ps(maxy + j), ly, _CMP_GE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(vminy, hy, _CMP_LE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(_mm256_loadu_ps(maxz + j), lz, _CMP_GE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(vminz, hz, _CMP_LE_OQ));
      if (_mm256_movemask_ps(c)) {
        c = _mm256_and_ps(c, dedup::owns_sorted_x(rv, ly, lz, vminx, vminy, vminz));
        out.emit(in.ids[i], in.ids + j, static_cast<unsigned>(_mm256_movemask_ps(c)));
      }
      if (mx != 0xFF) break;
    }
  }

  template <class Out>
  static void allpairs_row(const KernelInput& in, const RegionVec& rv, std::uint32_t i, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
    const __m256 lx = _mm256_set1_ps(minx[i]), hx = _mm256_set1_ps(maxx[i]);
    const __m256 ly = _mm256_set1_ps(miny[i]), hy = _mm256_set1_ps(maxy[i]);
    const __m256 lz = _mm256_set1_ps(minz[i]), hz = _mm256_set1_ps(maxz[i]);
    for (std::uint32_t j = i + 1; j < in.n; j += 8) {
      const __m256 vminx = _mm256_loadu_ps(minx + j), vminy = _mm256_loadu_ps(miny + j),
                   vminz = _mm256_loadu_ps(minz + j);
      __m256 c = _mm256_and_ps(_mm256_cmp_ps(_mm256_loadu_ps(maxx + j), lx, _CMP_GE_OQ),
                               _mm256_cmp_ps(vminx, hx, _CMP_LE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(_mm256_loadu_ps(maxy + j), ly, _CMP_GE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(vminy, hy, _CMP_LE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(_mm256_loadu_ps(maxz + j), lz, _CMP_GE_OQ));
      c = _mm256_and_ps(c, _mm256_cmp_ps(vminz, hz, _CMP_LE_OQ));
      if (_mm256_movemask_ps(c)) {
        c = _mm256_and_ps(c, dedup::owns(rv, lx, ly, lz, vminx, vminy, vminz));
        out.emit(in.ids[i], in.ids + j, static_cast<unsigned>(_mm256_movemask_ps(c)));
      }
    }
  }
};

}  // namespace

constinit const KernelSet kAvx2Kernels = KernelsOf<Rows, Store, Count>::set(canonical_pairs_scalar);

}  // namespace hbp::kernels
