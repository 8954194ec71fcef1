// SPDX-License-Identifier: MIT
#pragma once
// Which sanitizer instruments this test binary (g++ defines __SANITIZE_*__,
// clang answers __has_feature). Under either, resident memory and address
// space are not the library's alone (shadow memory, ASan's quarantine), so
// tests of those figures skip. Under ThreadSanitizer every memory access is
// instrumented (20 to 50 times slower); tests whose length buys confidence
// against rare divergence over many frames run shorter there, since a data
// race shows in the first frames, and at full length in the other builds.

#ifdef __has_feature
#define HBP_TEST_HAS_FEATURE(x) __has_feature(x)
#else
#define HBP_TEST_HAS_FEATURE(x) 0
#endif

namespace hbp::test {

#if defined(__SANITIZE_ADDRESS__) || HBP_TEST_HAS_FEATURE(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif

#if defined(__SANITIZE_THREAD__) || HBP_TEST_HAS_FEATURE(thread_sanitizer)
inline constexpr bool kThreadSanitizer = true;
#else
inline constexpr bool kThreadSanitizer = false;
#endif

}  // namespace hbp::test
