// SPDX-License-Identifier: MIT
#pragma once
// Which sanitizer instruments this test binary (g++ defines __SANITIZE_*__,
// clang answers __has_feature). Under either, resident memory and address
// space are not the library's alone (shadow memory, ASan's quarantine), so
// tests of those figures skip. Under ThreadSanitizer every memory access is
// instrumented (20 to 50 times slower); tests whose length buys confidence
// against rare divergence over many frames run shorter there, since a data
// race shows in the first frames, and at full length in the other builds.

namespace hbp::test {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

#if defined(__SANITIZE_THREAD__)
inline constexpr bool kThreadSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
inline constexpr bool kThreadSanitizer = true;
#else
inline constexpr bool kThreadSanitizer = false;
#endif
#else
inline constexpr bool kThreadSanitizer = false;
#endif

}  // namespace hbp::test
