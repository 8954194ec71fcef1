// SPDX-License-Identifier: MIT
#pragma once
// The AVX2 lanes of the ownership rule (ownership_lanes.hpp): 8 candidates at
// once, masks as all-ones float lanes. Include only from files compiled for
// AVX2 (engines/box_kernels_avx2.cpp).
#include <immintrin.h>

#include "dedup/ownership_lanes.hpp"

namespace hbp::dedup {
namespace {

struct Avx2Lanes {
  using Vec = __m256;
  using Mask = __m256;
  static Vec broadcast(float x) { return _mm256_set1_ps(x); }
  static Vec max(Vec a, Vec b) { return _mm256_max_ps(a, b); }
  static Mask within(Vec p, Vec lo, Vec hi) {
    return _mm256_and_ps(_mm256_cmp_ps(p, lo, _CMP_GE_OQ), _mm256_cmp_ps(p, hi, _CMP_LT_OQ));
  }
  static Mask within(Mask m, Vec p, Vec lo, Vec hi) { return _mm256_and_ps(m, within(p, lo, hi)); }
};

}  // namespace
}  // namespace hbp::dedup
