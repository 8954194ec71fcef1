// SPDX-License-Identifier: MIT
// GCC 12 reports its own _mm512_undefined_ps() inside _mm512_max_ps as
// "may be used uninitialized" (a false positive in the intrinsic header).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include <algorithm>

#include "dedup/ownership.hpp"
#include "engines/box_kernel_rows.hpp"
#include "engines/box_kernels.hpp"

namespace hbp::kernels {

namespace {

// Vectors of candidates every sweep row scans before it tests for its end
// (paper scene, 1,024,000 objects: rows reach 2.6 vectors on average; 3
// took 9 % fewer kernel samples than 1, 2 and 4 about as many as 1).
constexpr std::uint32_t kSweepVectors = 3;

// Where a row's hits go: stored (row id, candidate id), or only counted.
struct Store {
  std::uint32_t* first;
  std::uint32_t* second;
  std::size_t count;
  // Branch-free: compress the hit lanes' ids into the front of a vector and
  // store all 16 lanes (the output keeps kOutputSlack spare entries); a
  // branch on "any hit" mispredicts too often to pay.
  void emit(__m512i id_i, const std::uint32_t* ids_j, __mmask16 mask) {
    _mm512_storeu_si512(second + count, _mm512_maskz_compress_epi32(mask, _mm512_loadu_si512(ids_j)));
    _mm512_storeu_si512(first + count, id_i);
    count += static_cast<std::size_t>(__builtin_popcount(mask));
  }
};

struct Count {
  std::uint64_t count = 0;
  void emit(__m512i, const std::uint32_t*, __mmask16 mask) { count += static_cast<std::uint64_t>(__builtin_popcount(mask)); }
};

// The paired sweep's hit sinks take a vector of candidates j..j+15 and
// both rows' masks at once.
struct PairStore : Store {
  void emit_pair(std::uint32_t j, const std::uint32_t* ids, __m512i id0, __m512i id1, __mmask16 m0, __mmask16 m1) {
    const __m512i v = _mm512_loadu_si512(ids + j);
    emit_vector(id0, v, m0);
    emit_vector(id1, v, m1);
  }
  void emit_vector(__m512i id_i, __m512i ids_j, __mmask16 mask) {
    _mm512_storeu_si512(second + count, _mm512_maskz_compress_epi32(mask, ids_j));
    _mm512_storeu_si512(first + count, id_i);
    count += static_cast<std::size_t>(__builtin_popcount(mask));
  }
};
struct PairCount : Count {
  void emit_pair(std::uint32_t, const std::uint32_t*, __m512i, __m512i, __mmask16 m0, __mmask16 m1) {
    count += static_cast<std::uint64_t>(__builtin_popcount(m0) + __builtin_popcount(m1));
  }
};

// Deferred emission: a pair of rows' scan records each vector's position
// and masks (8 bytes at a fixed stride), and the hits are stored from the
// records after the scan. Storing them during the scan made every store's
// address depend on the masks of the vector before (the running count),
// at the end of the compares' latency; the storing sweep then took ~40 %
// longer than one whose stores went to fixed addresses (clustered
// 1,000,000, one thread, all cells of frame 0). Same hits, same order.
struct StepRecord {
  std::uint32_t j;
  std::uint16_t m0, m1;
};
// Records a pair of rows may need: one per vector scanned, at most n / 16 + 1
// of them (a vector at j is read only while j <= n). Cells of more boxes
// store during the scan, as before.
constexpr std::uint32_t kDeferredRecords = 1040;
constexpr std::uint32_t kDeferredMaxBoxes = 16 * (kDeferredRecords - 8);
struct Deferred {
  StepRecord* records;
  std::uint32_t k = 0;
  void emit_pair(std::uint32_t j, const std::uint32_t*, __m512i, __m512i, __mmask16 m0, __mmask16 m1) {
    records[k++] = {j, static_cast<std::uint16_t>(m0), static_cast<std::uint16_t>(m1)};
  }
};

// A row's owner demand (dedup::owner_demand) in every lane: its candidates
// are owned where (owner code & demand) == 0.
inline __m512i demand_of(const KernelInput& in, std::uint32_t i) {
  return _mm512_set1_epi32(static_cast<int>(dedup::owner_demand(~in.owner_codes[i])));
}

// The lanes of candidates j..j+15 the row of `demand` owns a pair with.
inline __mmask16 owned(const KernelInput& in, std::uint32_t j, __m512i demand) {
  return _mm512_testn_epi32_mask(_mm512_loadu_si512(in.owner_codes + j), demand);
}

// This ISA's rows, for KernelsOf (box_kernel_rows.hpp). Ownership comes from
// the boxes' owner codes, not the region.
struct Rows {
  static const CellRegion& region(const CellRegion& r) { return r; }

  template <class Out>
  [[gnu::always_inline]] static void sweep_row(const KernelInput& in, const CellRegion&, std::uint32_t i, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxy = in.max[1], *maxz = in.max[2];
    const __m512 bx = _mm512_set1_ps(in.max[0][i]);
    const __m512 ly = _mm512_set1_ps(miny[i]), hy = _mm512_set1_ps(maxy[i]);
    const __m512 lz = _mm512_set1_ps(minz[i]), hz = _mm512_set1_ps(maxz[i]);
    const __m512i id_i = _mm512_set1_epi32(static_cast<int>(in.ids[i]));
    const __m512i demand = demand_of(in, i);
    // One vector of candidates j..j+15; returns the lanes within the row's
    // x reach (all 16: the scan goes on).
    auto step = [&](std::uint32_t j) {
      const __mmask16 mx = _mm512_cmp_ps_mask(_mm512_loadu_ps(minx + j), bx, _CMP_LE_OQ);
      // Independent compares joined by kand: a short dependency chain.
      const __mmask16 my = _mm512_cmp_ps_mask(_mm512_loadu_ps(maxy + j), ly, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(_mm512_loadu_ps(miny + j), hy, _CMP_LE_OQ);
      const __mmask16 mz = _mm512_cmp_ps_mask(_mm512_loadu_ps(maxz + j), lz, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(_mm512_loadu_ps(minz + j), hz, _CMP_LE_OQ);
      const __mmask16 m = mx & my & mz & owned(in, j, demand);
      out.emit(id_i, in.ids + j, m);
      return mx;
    };
    // The first kSweepVectors vectors run without a data-dependent exit:
    // a row's reach varies from row to row, so an exit test after every
    // vector mispredicts about once a row, which costs more than the few
    // vectors scanned past the reach (boxes are sorted by min x: once a
    // lane is out of reach every later one is, and such lanes emit nothing).
    // Index n is a padding box (min = +inf), so a vector that covers it ends
    // the scan; the padding spans 16 floats past n, so a vector at j is read
    // only while j <= n.
    std::uint32_t j = i + 1;
    __mmask16 mx = step(j);
    for (std::uint32_t k = 1; k < kSweepVectors; ++k) {
      if (j + 16 > in.n) return;  // the vector at j covered the padding
      j += 16;
      mx = step(j);
    }
    while (mx == 0xFFFF) {
      j += 16;
      mx = step(j);
    }
  }

  template <class Out>
  [[gnu::always_inline]] static void allpairs_row(const KernelInput& in, const CellRegion&, std::uint32_t i, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
    const __m512 lx = _mm512_set1_ps(minx[i]), hx = _mm512_set1_ps(maxx[i]);
    const __m512 ly = _mm512_set1_ps(miny[i]), hy = _mm512_set1_ps(maxy[i]);
    const __m512 lz = _mm512_set1_ps(minz[i]), hz = _mm512_set1_ps(maxz[i]);
    const __m512i id_i = _mm512_set1_epi32(static_cast<int>(in.ids[i]));
    const __m512i demand = demand_of(in, i);
    for (std::uint32_t j = i + 1; j < in.n; j += 16) {
      __mmask16 m = _mm512_cmp_ps_mask(_mm512_loadu_ps(maxx + j), lx, _CMP_GE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(minx + j), hx, _CMP_LE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(maxy + j), ly, _CMP_GE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(miny + j), hy, _CMP_LE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(maxz + j), lz, _CMP_GE_OQ);
      m = _mm512_mask_cmp_ps_mask(m, _mm512_loadu_ps(minz + j), hz, _CMP_LE_OQ);
      if (m) {
        m &= owned(in, j, demand);
        out.emit(id_i, in.ids + j, m);
      }
    }
  }
};

// Two sweep rows at once: rows i and i + 1 scan nearly the same candidates,
// so each vector of candidates is loaded once and tested against both, and
// the pair stops once, when both rows are past their reach (one exit
// mispredict per two rows). Hits come per vector, row i's before row
// i + 1's: an order of its own, the same for any thread count.
struct PairedRows {
  // `below`: the boxes [0, below) have min x < the region's lo x (a prefix:
  // boxes come in min-x order). Two of them own no pair (the ownership
  // point's x is the larger min x, still below lo), so a pair of rows both
  // in the prefix starts its candidates at `below`, past the ones it would
  // only reject (cells whose boxes straddle their low x plane).
  template <class Out>
  [[gnu::always_inline]] static void sweep_rows(const KernelInput& in, std::uint32_t i, std::uint32_t below, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxy = in.max[1], *maxz = in.max[2];
    const __m512 bx0 = _mm512_set1_ps(in.max[0][i]), bx1 = _mm512_set1_ps(in.max[0][i + 1]);
    const __m512 ly0 = _mm512_set1_ps(miny[i]), hy0 = _mm512_set1_ps(maxy[i]);
    const __m512 lz0 = _mm512_set1_ps(minz[i]), hz0 = _mm512_set1_ps(maxz[i]);
    const __m512 ly1 = _mm512_set1_ps(miny[i + 1]), hy1 = _mm512_set1_ps(maxy[i + 1]);
    const __m512 lz1 = _mm512_set1_ps(minz[i + 1]), hz1 = _mm512_set1_ps(maxz[i + 1]);
    const __m512i id0 = _mm512_set1_epi32(static_cast<int>(in.ids[i]));
    const __m512i id1 = _mm512_set1_epi32(static_cast<int>(in.ids[i + 1]));
    const __m512i demand0 = demand_of(in, i), demand1 = demand_of(in, i + 1);
    // One vector of candidates j..j+15 against both rows; `own` drops row
    // i + 1's own lane (the first vector starts at it). Returns whether
    // either row's reach covers all 16 lanes (the scan goes on).
    auto step = [&](std::uint32_t j, __mmask16 own) {
      const __m512 vminx = _mm512_loadu_ps(minx + j);
      const __m512 vminy = _mm512_loadu_ps(miny + j), vminz = _mm512_loadu_ps(minz + j);
      const __m512 vmaxy = _mm512_loadu_ps(maxy + j), vmaxz = _mm512_loadu_ps(maxz + j);
      const __m512i codes = _mm512_loadu_si512(in.owner_codes + j);
      const __mmask16 mx0 = _mm512_cmp_ps_mask(vminx, bx0, _CMP_LE_OQ);
      const __mmask16 mx1 = _mm512_cmp_ps_mask(vminx, bx1, _CMP_LE_OQ);
      const __mmask16 m0 = mx0 & _mm512_cmp_ps_mask(vmaxy, ly0, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(vminy, hy0, _CMP_LE_OQ) & _mm512_cmp_ps_mask(vmaxz, lz0, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(vminz, hz0, _CMP_LE_OQ) & _mm512_testn_epi32_mask(codes, demand0);
      const __mmask16 m1 = mx1 & own & _mm512_cmp_ps_mask(vmaxy, ly1, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(vminy, hy1, _CMP_LE_OQ) & _mm512_cmp_ps_mask(vmaxz, lz1, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(vminz, hz1, _CMP_LE_OQ) & _mm512_testn_epi32_mask(codes, demand1);
      out.emit_pair(j, in.ids, id0, id1, m0, m1);
      return (mx0 == 0xFFFF) | (mx1 == 0xFFFF);
    };
    // As in Rows::sweep_row: the first kSweepVectors vectors without an exit
    // test; a vector at j is read only while j <= n (index n is padding).
    std::uint32_t j = i + 1;
    __mmask16 own = 0xFFFE;
    if (i + 1 < below) {
      j = below;
      own = 0xFFFF;
    }
    bool more = step(j, own);
    for (std::uint32_t k = 1; k < kSweepVectors; ++k) {
      if (j + 16 > in.n) return;  // the vector at j covered the padding
      j += 16;
      more = step(j, 0xFFFF);
    }
    while (more) {
      j += 16;
      more = step(j, 0xFFFF);
    }
  }

  // Rows from `row` on, two at a time while the output has room for both,
  // the last one alone when n - row is odd. The pairs of rows are always
  // (row + 2k, row + 2k + 1), whatever the room (callers start at 0 and
  // resume where the kernel stopped), so the hits come in the same order
  // however the output is drained.
  // The boxes with min x below the region's lo x (see sweep_rows).
  static std::uint32_t below_lo(const KernelInput& in) {
    const float lo = in.region.lo[0];
    return static_cast<std::uint32_t>(std::lower_bound(in.min[0], in.min[0] + in.n, lo) - in.min[0]);
  }

  static std::uint32_t sweep(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
    const std::uint32_t below = below_lo(in);
    PairStore s{{out.first, out.second, out.count}};
    std::uint32_t i = row;
    if (in.n <= kDeferredMaxBoxes) {
      StepRecord records[kDeferredRecords];
      for (; i + 1 < in.n; i += 2) {
        if (out.capacity - s.count < 2 * std::size_t{in.n - i} + kOutputSlack) break;
        Deferred d{records};
        sweep_rows(in, i, below, d);
        const __m512i id0 = _mm512_set1_epi32(static_cast<int>(in.ids[i]));
        const __m512i id1 = _mm512_set1_epi32(static_cast<int>(in.ids[i + 1]));
        for (std::uint32_t k = 0; k < d.k; ++k)
          s.emit_pair(records[k].j, in.ids, id0, id1, records[k].m0, records[k].m1);
      }
    } else {
      for (; i + 1 < in.n; i += 2) {
        if (out.capacity - s.count < 2 * std::size_t{in.n - i} + kOutputSlack) break;
        sweep_rows(in, i, below, s);
      }
    }
    if (i + 1 == in.n && out.capacity - s.count >= std::size_t{1} + kOutputSlack) {
      Rows::sweep_row(in, in.region, i, s);
      i += 1;
    }
    out.count = s.count;
    return i;
  }
  static std::uint64_t sweep_count(const KernelInput& in, std::uint32_t row) {
    const std::uint32_t below = below_lo(in);
    PairCount c;
    std::uint32_t i = row;
    for (; i + 1 < in.n; i += 2) sweep_rows(in, i, below, c);
    if (i < in.n) Rows::sweep_row(in, in.region, i, c);
    return c.count;
  }
};

}  // namespace

constinit const KernelSet kAvx512Kernels = {PairedRows::sweep, KernelsOf<Rows, Store, Count>::allpairs,
                                            PairedRows::sweep_count, KernelsOf<Rows, Store, Count>::allpairs_count,
                                            canonical_pairs_avx512};

void canonical_pairs_avx512(const std::uint32_t* first, const std::uint32_t* second, std::size_t count,
                            std::uint32_t* pairs) {
  const __m512i lo_idx = _mm512_set_epi32(23, 7, 22, 6, 21, 5, 20, 4, 19, 3, 18, 2, 17, 1, 16, 0);
  const __m512i hi_idx = _mm512_set_epi32(31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9, 24, 8);
  std::size_t k = 0;
  for (; k + 16 <= count; k += 16) {
    const __m512i f = _mm512_loadu_si512(first + k), s = _mm512_loadu_si512(second + k);
    const __m512i a = _mm512_min_epu32(f, s), b = _mm512_max_epu32(f, s);
    _mm512_storeu_si512(pairs + 2 * k, _mm512_permutex2var_epi32(a, lo_idx, b));
    _mm512_storeu_si512(pairs + 2 * k + 16, _mm512_permutex2var_epi32(a, hi_idx, b));
  }
  if (k == count) return;
  // The tail: masked, the destination may end right after the last pair.
  const unsigned rest = static_cast<unsigned>(count - k);
  const __mmask16 m = static_cast<__mmask16>((1u << rest) - 1);
  const __m512i f = _mm512_maskz_loadu_epi32(m, first + k), s = _mm512_maskz_loadu_epi32(m, second + k);
  const __m512i a = _mm512_min_epu32(f, s), b = _mm512_max_epu32(f, s);
  const auto lo_mask = static_cast<__mmask16>(rest >= 8 ? 0xFFFFu : (1u << (2 * rest)) - 1);
  const auto hi_mask = static_cast<__mmask16>(rest <= 8 ? 0u : (1u << (2 * (rest - 8))) - 1);
  _mm512_mask_storeu_epi32(pairs + 2 * k, lo_mask, _mm512_permutex2var_epi32(a, lo_idx, b));
  _mm512_mask_storeu_epi32(pairs + 2 * k + 16, hi_mask, _mm512_permutex2var_epi32(a, hi_idx, b));
}

}  // namespace hbp::kernels
