// SPDX-License-Identifier: MIT
#pragma once
// Run-time checks of the processor's vector extensions. The library is built
// for plain x86-64; its AVX2 paths (functions with target("avx2") beside
// their scalar reference) are taken when the processor has them.
#if defined(__x86_64__) && defined(__GNUC__)
#define HBP_X86_64_GNU 1
#endif

namespace hbp {

#if HBP_X86_64_GNU
inline bool cpu_has_avx2() {
  static const bool avx2 = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return avx2;
}
#endif

}  // namespace hbp
