#include <cstdlib>
#include <cstring>

#include "engines/box_kernels.hpp"

namespace hbp::kernels {

namespace {

Isa best_supported() {
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
      __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("bmi2"))
    return Isa::Avx512;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi2")) return Isa::Avx2;
  return Isa::Scalar;
}

Isa choose() {
  const Isa best = best_supported();
  const char* env = std::getenv("HBP_SIMD");
  if (env == nullptr) return best;
  Isa want = best;
  if (std::strcmp(env, "scalar") == 0) want = Isa::Scalar;
  if (std::strcmp(env, "avx2") == 0) want = Isa::Avx2;
  if (std::strcmp(env, "avx512") == 0) want = Isa::Avx512;
  return static_cast<int>(want) <= static_cast<int>(best) ? want : best;
}

}  // namespace

Isa selected_isa() {
  static const Isa isa = choose();
  return isa;
}

const char* isa_name(Isa isa) {
  switch (isa) {
    case Isa::Scalar: return "scalar";
    case Isa::Avx2: return "avx2";
    case Isa::Avx512: return "avx512";
  }
  return "scalar";
}

Kernel sweep_kernel(Isa isa) {
  switch (isa) {
    case Isa::Avx512: return sweep_avx512;
    case Isa::Avx2: return sweep_avx2;
    case Isa::Scalar: break;
  }
  return sweep_scalar;
}

Kernel allpairs_kernel(Isa isa) {
  switch (isa) {
    case Isa::Avx512: return allpairs_avx512;
    case Isa::Avx2: return allpairs_avx2;
    case Isa::Scalar: break;
  }
  return allpairs_scalar;
}

}  // namespace hbp::kernels

namespace hbp::kernels {

CountKernel sweep_count_kernel(Isa isa) {
  switch (isa) {
    case Isa::Avx512: return sweep_count_avx512;
    case Isa::Avx2: return sweep_count_avx2;
    case Isa::Scalar: break;
  }
  return sweep_count_scalar;
}

CountKernel allpairs_count_kernel(Isa isa) {
  switch (isa) {
    case Isa::Avx512: return allpairs_count_avx512;
    case Isa::Avx2: return allpairs_count_avx2;
    case Isa::Scalar: break;
  }
  return allpairs_count_scalar;
}

CanonicalPairs canonical_pairs(Isa isa) {
  // The scalar loop vectorises well enough without AVX-512's permutes.
  return isa == Isa::Avx512 ? canonical_pairs_avx512 : canonical_pairs_scalar;
}

}  // namespace hbp::kernels
