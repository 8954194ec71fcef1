/* SPDX-License-Identifier: MIT */
/*
 * What the C API tests share: CHECK(cond, fmt, ...) prints the failed
 * condition with a message, counts it in check_failures and returns 1 from
 * the calling function; rnd() / rnd_below(n) / rnd_unit() are a
 * deterministic xorshift generator (seed it with rnd_seed or by mixing into
 * rng_state), the same sequence on every platform. Then the pieces of the
 * brute-force oracles: grid boxes, the closed-box overlap and segment tests,
 * pair and handle order, and sorted pair lists with their differences.
 */
#ifndef HBP_TESTS_CAPI_CHECK_H
#define HBP_TESTS_CAPI_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "hbp/hbp.h"

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
static inline unsigned long long rnd_next(void) {
  rng_state ^= rng_state << 13;
  rng_state ^= rng_state >> 7;
  rng_state ^= rng_state << 17;
  return rng_state;
}
static inline unsigned rnd(void) { return (unsigned)(rnd_next() >> 16); }
static inline unsigned rnd_below(unsigned n) { return rnd() % n; }
/* Uniform in [0, 1): the top 53 bits. */
static inline double rnd_unit(void) { return (double)(rnd_next() >> 11) / 9007199254740992.0; }
static inline void rnd_seed(unsigned seed) { rng_state ^= (unsigned long long)seed * 0x9E3779B97F4A7C15ull; }

/* The usual command line: [seed [count]]; seeds the generator and returns
   the count (default_count when not given). */
static inline unsigned seed_and_count(int argc, char** argv, unsigned default_count) {
  rnd_seed(argc > 1 ? (unsigned)atoi(argv[1]) : 1u);
  return argc > 2 ? (unsigned)atoi(argv[2]) : default_count;
}

/* *bp: a broad phase with the default options but `threads`. */
static inline int create_with_threads(uint32_t threads, hbp_broad_phase** bp) {
  hbp_options o;
  hbp_options_init(&o);
  o.threads = threads;
  CHECK(hbp_create(&o, bp) == HBP_OK, "%s", hbp_last_error());
  return 0;
}

/* run(count, 1) then run(count, 2): 0 and "ok" when both pass, else 1. */
static inline int run_1_and_2_threads(int (*run)(unsigned, uint32_t), unsigned count) {
  if (run(count, 1) || run(count, 2)) return 1;
  printf("ok\n");
  return 0;
}

/* A box on a 0.5 grid, min 0.5 * [0, cells), size 0.5 * [0, sizes) per axis:
   touching faces are frequent, and exact in float; zero-size boxes too. */
static inline hbp_box grid_box(unsigned cells, unsigned sizes) {
  hbp_box b;
  int k;
  for (k = 0; k < 3; ++k) {
    b.min[k] = 0.5f * (float)rnd_below(cells);
    b.max[k] = b.min[k] + 0.5f * (float)rnd_below(sizes);
  }
  return b;
}

/* Closed boxes: touching faces overlap. */
static inline int overlaps(const hbp_box* a, const hbp_box* b) {
  int k;
  for (k = 0; k < 3; ++k)
    if (a->max[k] < b->min[k] || a->min[k] > b->max[k]) return 0;
  return 1;
}

/* RaySegment::hits of the library, operation for operation (float): the
   segment o + t d, 0 <= t <= max_t, against the closed box [mn, mx]; an axis
   with d = 0 (or 1/d infinite) needs o inside the slab. */
static inline int ray_entry(const float o[3], const float d[3], float max_t, const float mn[3], const float mx[3],
                            float* entry) {
  float t0 = 0.0f, t1 = max_t;
  int k;
  for (k = 0; k < 3; ++k) {
    float inv = 1.0f / d[k];
    if (d[k] == 0.0f || isinf(inv)) {
      if (o[k] < mn[k] || o[k] > mx[k]) return 0;
      continue;
    }
    {
      float a = (mn[k] - o[k]) * inv;
      float c = (mx[k] - o[k]) * inv;
      if (a > c) {
        float s = a;
        a = c;
        c = s;
      }
      if (a > t0) t0 = a;
      if (c < t1) t1 = c;
    }
  }
  if (!(t0 <= t1)) return 0;
  *entry = t0;
  return 1;
}

/* A ray or cast hit; cmp_ray_hit orders by entry t, then handle (the API's order). */
typedef struct {
  float t;
  hbp_handle h;
} ray_hit;
static inline int cmp_ray_hit(const void* x, const void* y) {
  const ray_hit* p = (const ray_hit*)x;
  const ray_hit* q = (const ray_hit*)y;
  if (p->t != q->t) return p->t < q->t ? -1 : 1;
  return p->h < q->h ? -1 : p->h > q->h ? 1 : 0;
}

static inline int pair_less(const hbp_pair* x, const hbp_pair* y) {
  return x->a < y->a || (x->a == y->a && x->b < y->b);
}
static inline int cmp_pair(const void* x, const void* y) {
  const hbp_pair* p = (const hbp_pair*)x;
  const hbp_pair* q = (const hbp_pair*)y;
  return pair_less(p, q) ? -1 : pair_less(q, p) ? 1 : 0;
}
static inline int cmp_handle(const void* x, const void* y) {
  const hbp_handle a = *(const hbp_handle*)x, b = *(const hbp_handle*)y;
  return a < b ? -1 : a > b ? 1 : 0;
}

/* A growing list of pairs (start it zeroed). */
typedef struct {
  hbp_pair* v;
  size_t n, cap;
} pair_list;
static inline void push_pair(pair_list* l, hbp_pair p) {
  if (l->n == l->cap) {
    l->cap = l->cap ? 2 * l->cap : 1024;
    l->v = (hbp_pair*)realloc(l->v, l->cap * sizeof(hbp_pair));
    if (!l->v) {
      fprintf(stderr, "out of memory\n");
      exit(2);
    }
  }
  l->v[l->n++] = p;
}
/* The pair of a and b, smaller handle first. */
static inline hbp_pair ordered_pair(hbp_handle a, hbp_handle b) {
  hbp_pair p;
  p.a = a < b ? a : b;
  p.b = a < b ? b : a;
  return p;
}

/* Pairs of `from` not in `minus` (both sorted). */
static inline void difference(const pair_list* from, const pair_list* minus, pair_list* out) {
  size_t i = 0, j = 0;
  out->n = 0;
  while (i < from->n) {
    if (j == minus->n || pair_less(&from->v[i], &minus->v[j])) {
      push_pair(out, from->v[i++]);
    } else if (pair_less(&minus->v[j], &from->v[i])) {
      ++j;
    } else {
      ++i;
      ++j;
    }
  }
}

/* got[0 .. n) is the oracle's list, pair for pair. */
static inline int same_pairs(const char* what, unsigned frame, const hbp_pair* got, size_t n, const pair_list* want) {
  size_t i;
  CHECK(n == want->n, "frame %u: %s: %lu pairs, oracle %lu", frame, what, (unsigned long)n, (unsigned long)want->n);
  for (i = 0; i < n; ++i)
    CHECK(got[i].a == want->v[i].a && got[i].b == want->v[i].b, "frame %u: %s[%lu] = %u-%u, oracle %u-%u", frame,
          what, (unsigned long)i, got[i].a, got[i].b, want->v[i].a, want->v[i].b);
  return 0;
}

#endif
