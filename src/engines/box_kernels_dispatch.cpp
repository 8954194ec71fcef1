// SPDX-License-Identifier: MIT
#include <cstdlib>
#include <cstring>
#include <string>

#include "dedup/ownership.hpp"
#include "engines/box_kernels.hpp"
#include "hbp/error.hpp"

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

Isa choose() { return isa_for_request(std::getenv("HBP_SIMD"), best_supported()); }

}  // namespace

Isa isa_for_request(const char* request, Isa best) {
  if (request == nullptr || *request == '\0') return best;
  Isa want;
  if (std::strcmp(request, "scalar") == 0) {
    want = Isa::Scalar;
  } else if (std::strcmp(request, "avx2") == 0) {
    want = Isa::Avx2;
  } else if (std::strcmp(request, "avx512") == 0) {
    want = Isa::Avx512;
  } else {
    throw InvalidInput(std::string("HBP_SIMD=") + request +
                       " is not an instruction set: use scalar, avx2 or avx512 (lower case), or leave HBP_SIMD unset "
                       "for the best this CPU supports");
  }
  return static_cast<int>(want) <= static_cast<int>(best) ? want : best;
}

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

const KernelSet& kernel_set(Isa isa) {
  switch (isa) {
    case Isa::Avx512: return kAvx512Kernels;
    case Isa::Avx2: return kAvx2Kernels;
    case Isa::Scalar: break;
  }
  return kScalarKernels;
}

Kernel sweep_kernel(Isa isa) { return kernel_set(isa).sweep; }
Kernel allpairs_kernel(Isa isa) { return kernel_set(isa).allpairs; }
CountKernel sweep_count_kernel(Isa isa) { return kernel_set(isa).sweep_count; }
CountKernel allpairs_count_kernel(Isa isa) { return kernel_set(isa).allpairs_count; }
CanonicalPairs canonical_pairs(Isa isa) { return kernel_set(isa).canonical_pairs; }

void write_owner_codes(const float* const min[3], std::uint32_t n, const CellRegion& r, std::uint32_t* codes) {
  for (std::uint32_t i = 0; i < n; ++i) codes[i] = dedup::owner_code(dedup::sides(r, min[0][i], min[1][i], min[2][i]));
  for (std::uint32_t k = 0; k < 16; ++k) codes[n + k] = ~0u;  // fails every side: owns nothing
}

}  // namespace hbp::kernels
