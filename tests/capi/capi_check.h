/* SPDX-License-Identifier: MIT */
/*
 * What the C API tests share: CHECK(cond, fmt, ...) prints the failed
 * condition with a message, counts it in check_failures and returns 1 from
 * the calling function; rnd() / rnd_below(n) are a deterministic xorshift
 * generator (seed it by mixing into rng_state), the same sequence on every
 * platform.
 */
#ifndef HBP_TESTS_CAPI_CHECK_H
#define HBP_TESTS_CAPI_CHECK_H

#include <stdio.h>

static int check_failures = 0;

#define CHECK(cond, ...)                                                        \
  do {                                                                          \
    if (!(cond)) {                                                              \
      fprintf(stderr, "%s:%d: check failed: %s: ", __FILE__, __LINE__, #cond); \
      fprintf(stderr, __VA_ARGS__);                                             \
      fprintf(stderr, "\n");                                                    \
      ++check_failures;                                                         \
      return 1;                                                                 \
    }                                                                           \
  } while (0)

static unsigned long long rng_state = 88172645463325252ull;
static inline unsigned rnd(void) {
  rng_state ^= rng_state << 13;
  rng_state ^= rng_state >> 7;
  rng_state ^= rng_state << 17;
  return (unsigned)(rng_state >> 16);
}
static inline unsigned rnd_below(unsigned n) { return rnd() % n; }

#endif
