// SPDX-License-Identifier: MIT
#include "pipeline/box_transpose.hpp"

#include "geometry/box_screen.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace hbp::detail {

namespace {

bool check_and_transpose_scalar(const Aabb* boxes, const std::uint32_t* ids, const std::uint32_t* expected,
                                std::size_t begin, std::size_t end, float* const lane[6],
                                const float* const* previous, std::uint32_t& changed) {
  bool ok = true;
  for (std::size_t i = begin; i < end; ++i) {
    ok &= ids[i] == (expected ? expected[i] : static_cast<std::uint32_t>(i));
    bool differs = false;
    for (int k = 0; k < 3; ++k) {
      const float lo = boxes[i].min[k], hi = boxes[i].max[k];
      ok &= !geometry::interval_fails(lo, hi);
      if (previous) differs |= (previous[k][i] != lo) | (previous[3 + k][i] != hi);
      lane[k][i] = lo;
      lane[3 + k][i] = hi;
    }
    changed += differs;
  }
  return ok;
}

#if defined(__SSE2__)
// Four lane values; kStream: a non-temporal store (p is 16-byte aligned).
template <bool kStream>
inline void store_lane(float* p, __m128 v) {
  if constexpr (kStream) {
    _mm_stream_ps(p, v);
  } else {
    _mm_storeu_ps(p, v);
  }
}

// The SSE2 body; kStream: the lanes are 16-byte aligned at begin and written
// with non-temporal stores (a whole-world batch is far larger than the
// caches: a normal store would first read each line it writes).
template <bool kStream>
bool check_and_transpose_sse2(const Aabb* boxes, const std::uint32_t* ids, const std::uint32_t* expected,
                              std::size_t begin, std::size_t end, float* const lane[6],
                              const float* const* previous, std::uint32_t& changed) {
  static_assert(sizeof(Aabb) == 6 * sizeof(float), "four boxes are six vectors of four floats");
  const __m128 zero = _mm_setzero_ps();
  __m128 good = _mm_castsi128_ps(_mm_set1_epi32(-1));
  __m128i same = _mm_set1_epi32(-1);
  __m128i index = _mm_setr_epi32(0, 1, 2, 3);
  index = _mm_add_epi32(index, _mm_set1_epi32(static_cast<int>(begin)));
  const __m128i four = _mm_set1_epi32(4);
  std::size_t i = begin;
  for (; i + 4 <= end; i += 4) {
    // Four boxes = six vectors: v0 = x0 y0 z0 X0, v1 = Y0 Z0 x1 y1,
    // v2 = z1 X1 Y1 Z1, v3 = x2 y2 z2 X2, v4 = Y2 Z2 x3 y3, v5 = z3 X3 Y3 Z3
    // (lower case min, upper case max).
    const float* f = reinterpret_cast<const float*>(boxes + i);
    const __m128 v0 = _mm_loadu_ps(f), v1 = _mm_loadu_ps(f + 4), v2 = _mm_loadu_ps(f + 8);
    const __m128 v3 = _mm_loadu_ps(f + 12), v4 = _mm_loadu_ps(f + 16), v5 = _mm_loadu_ps(f + 20);
    const __m128 a = _mm_shuffle_ps(v0, v1, _MM_SHUFFLE(3, 2, 1, 0));  // x0 y0 x1 y1
    const __m128 c = _mm_shuffle_ps(v3, v4, _MM_SHUFFLE(3, 2, 1, 0));  // x2 y2 x3 y3
    const __m128 d = _mm_shuffle_ps(v0, v2, _MM_SHUFFLE(1, 0, 3, 2));  // z0 X0 z1 X1
    const __m128 e = _mm_shuffle_ps(v3, v5, _MM_SHUFFLE(1, 0, 3, 2));  // z2 X2 z3 X3
    const __m128 g = _mm_shuffle_ps(v1, v2, _MM_SHUFFLE(3, 2, 1, 0));  // Y0 Z0 Y1 Z1
    const __m128 k = _mm_shuffle_ps(v4, v5, _MM_SHUFFLE(3, 2, 1, 0));  // Y2 Z2 Y3 Z3
    const __m128 min_x = _mm_shuffle_ps(a, c, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 min_y = _mm_shuffle_ps(a, c, _MM_SHUFFLE(3, 1, 3, 1));
    const __m128 min_z = _mm_shuffle_ps(d, e, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 max_x = _mm_shuffle_ps(d, e, _MM_SHUFFLE(3, 1, 3, 1));
    const __m128 max_y = _mm_shuffle_ps(g, k, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 max_z = _mm_shuffle_ps(g, k, _MM_SHUFFLE(3, 1, 3, 1));
    store_lane<kStream>(lane[0] + i, min_x);
    store_lane<kStream>(lane[1] + i, min_y);
    store_lane<kStream>(lane[2] + i, min_z);
    store_lane<kStream>(lane[3] + i, max_x);
    store_lane<kStream>(lane[4] + i, max_y);
    store_lane<kStream>(lane[5] + i, max_z);
    if (previous) {
      __m128 differs = _mm_cmpneq_ps(_mm_loadu_ps(previous[0] + i), min_x);
      differs = _mm_or_ps(differs, _mm_cmpneq_ps(_mm_loadu_ps(previous[1] + i), min_y));
      differs = _mm_or_ps(differs, _mm_cmpneq_ps(_mm_loadu_ps(previous[2] + i), min_z));
      differs = _mm_or_ps(differs, _mm_cmpneq_ps(_mm_loadu_ps(previous[3] + i), max_x));
      differs = _mm_or_ps(differs, _mm_cmpneq_ps(_mm_loadu_ps(previous[4] + i), max_y));
      differs = _mm_or_ps(differs, _mm_cmpneq_ps(_mm_loadu_ps(previous[5] + i), max_z));
      changed += static_cast<std::uint32_t>(__builtin_popcount(static_cast<unsigned>(_mm_movemask_ps(differs))));
    }
    // geometry::interval_fails in four lanes: every coordinate of the six
    // input vectors finite (x - x == 0), ordered per axis.
    __m128 finite = _mm_and_ps(_mm_cmpeq_ps(_mm_sub_ps(v0, v0), zero), _mm_cmpeq_ps(_mm_sub_ps(v1, v1), zero));
    finite = _mm_and_ps(finite, _mm_cmpeq_ps(_mm_sub_ps(v2, v2), zero));
    finite = _mm_and_ps(finite, _mm_cmpeq_ps(_mm_sub_ps(v3, v3), zero));
    finite = _mm_and_ps(finite, _mm_cmpeq_ps(_mm_sub_ps(v4, v4), zero));
    finite = _mm_and_ps(finite, _mm_cmpeq_ps(_mm_sub_ps(v5, v5), zero));
    const __m128 ordered = _mm_and_ps(_mm_and_ps(_mm_cmple_ps(min_x, max_x), _mm_cmple_ps(min_y, max_y)),
                                      _mm_cmple_ps(min_z, max_z));
    good = _mm_and_ps(good, _mm_and_ps(finite, ordered));
    const __m128i want =
        expected ? _mm_loadu_si128(reinterpret_cast<const __m128i*>(expected + i)) : index;
    same = _mm_and_si128(same, _mm_cmpeq_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(ids + i)), want));
    index = _mm_add_epi32(index, four);
  }
  if constexpr (kStream) _mm_sfence();  // the streamed lanes are visible before the caller reads them
  const bool ok = _mm_movemask_ps(good) == 0xF && _mm_movemask_epi8(same) == 0xFFFF;
  return check_and_transpose_scalar(boxes, ids, expected, i, end, lane, previous, changed) && ok;
}
#endif

}  // namespace

bool check_and_transpose(const Aabb* boxes, const std::uint32_t* ids, const std::uint32_t* expected,
                         std::size_t begin, std::size_t end, float* const lane[6], bool stream,
                         const float* const* previous, std::uint32_t* changed) {
  std::uint32_t differ = 0;
  bool ok;
#if defined(__SSE2__)
  bool aligned = true;
  for (int l = 0; l < 6; ++l) aligned &= reinterpret_cast<std::uintptr_t>(lane[l] + begin) % 16 == 0;
  if (stream && aligned)
    ok = check_and_transpose_sse2<true>(boxes, ids, expected, begin, end, lane, previous, differ);
  else
    ok = check_and_transpose_sse2<false>(boxes, ids, expected, begin, end, lane, previous, differ);
#else
  (void)stream;
  ok = check_and_transpose_scalar(boxes, ids, expected, begin, end, lane, previous, differ);
#endif
  if (changed) *changed = differ;
  return ok;
}

}  // namespace hbp::detail
