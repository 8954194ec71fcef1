// SPDX-License-Identifier: MIT
#pragma once
// The AVX-512 lanes of the ownership rule (ownership_lanes.hpp): 16
// candidates at once, masks as __mmask16, each test a masked compare (a chain
// that skips lanes already out). Include only from files compiled for AVX-512
// (engines/box_kernels_avx512.cpp).
#include <immintrin.h>

#include "dedup/ownership_lanes.hpp"

namespace hbp::dedup {
namespace {

struct Avx512Lanes {
  using Vec = __m512;
  using Mask = __mmask16;
  static Vec broadcast(float x) { return _mm512_set1_ps(x); }
  static Vec max(Vec a, Vec b) { return _mm512_max_ps(a, b); }
  static Mask within(Vec p, Vec lo, Vec hi) {
    return _mm512_mask_cmp_ps_mask(_mm512_cmp_ps_mask(p, lo, _CMP_GE_OQ), p, hi, _CMP_LT_OQ);
  }
  static Mask within(Mask m, Vec p, Vec lo, Vec hi) {
    return _mm512_mask_cmp_ps_mask(_mm512_mask_cmp_ps_mask(m, p, lo, _CMP_GE_OQ), p, hi, _CMP_LT_OQ);
  }
};

}  // namespace
}  // namespace hbp::dedup
