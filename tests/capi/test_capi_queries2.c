/* SPDX-License-Identifier: MIT */
/*
 * hbp_raycast_closest and hbp_box_cast from C99 against a brute-force
 * oracle written here (the library's float rules, operation for operation):
 * random add / move / remove / update sequences of static and moving
 * objects, rays and casts after every step, early-out casts, and the error
 * cases. Exits 0 when everything matches; else prints the first difference
 * and exits 1.
 *
 *   test_capi_queries2 [seed] [steps]   (each run with 1 and 2 threads)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define MAX_LIVE 600

static float rnd_float(float lo, float hi) { return lo + (hi - lo) * (float)rnd_below(1u << 20) / (float)(1u << 20); }

static hbp_box random_box(void) {
  hbp_box b;
  int k;
  for (k = 0; k < 3; ++k) {
    if (rnd_below(2)) {
      b.min[k] = 0.5f * (float)rnd_below(40);
      b.max[k] = b.min[k] + 0.5f * (float)rnd_below(7);
    } else {
      b.min[k] = rnd_float(-1.0f, 21.0f);
      b.max[k] = b.min[k] + rnd_float(0.0f, 3.0f);
    }
  }
  return b;
}

static hbp_handle live_handle[MAX_LIVE];
static hbp_box live_box[MAX_LIVE];
static size_t live = 0;

/* The box cast: the target grown by the box against the segment from 0. */
static int cast_entry(const hbp_box* box, const float d[3], const hbp_box* target, float* entry) {
  static const float zero[3] = {0.0f, 0.0f, 0.0f};
  float mn[3], mx[3];
  int k;
  for (k = 0; k < 3; ++k) {
    mn[k] = target->min[k] - box->max[k];
    mx[k] = target->max[k] - box->min[k];
  }
  return ray_entry(zero, d, 1.0f, mn, mx, entry);
}

typedef struct {
  hbp_handle got[MAX_LIVE];
  size_t n, stop_after; /* stop_after 0: never stop */
} collector;
static int collect(void* user, hbp_handle h) {
  collector* c = (collector*)user;
  c->got[c->n++] = h;
  return !(c->stop_after != 0 && c->n >= c->stop_after);
}

static void random_vec(float v[3], float scale) {
  int k;
  for (k = 0; k < 3; ++k) {
    switch (rnd_below(4)) {
      case 0: v[k] = 0.0f; break;
      case 1: v[k] = scale * 0.5f * ((float)rnd_below(9) - 4.0f); break;
      default: v[k] = rnd_float(-scale, scale);
    }
  }
}

static int check_queries(hbp_broad_phase* bp, unsigned step) {
  static ray_hit want[MAX_LIVE];
  static collector c;
  int q;
  for (q = 0; q < 4; ++q) {
    float o[3], d[3], t, max_t = rnd_below(5) == 0 ? INFINITY : rnd_float(0.0f, 40.0f);
    hbp_handle h;
    int found, k;
    size_t i, n = 0, calls;
    hbp_box box = random_box();
    for (k = 0; k < 3; ++k) o[k] = rnd_float(-2.0f, 22.0f);
    random_vec(d, 1.0f);
    /* Closest hit: the smallest (t, handle) of the scan. */
    for (i = 0; i < live; ++i)
      if (ray_entry(o, d, max_t, live_box[i].min, live_box[i].max, &t)) want[n].t = t, want[n++].h = live_handle[i];
    qsort(want, n, sizeof(ray_hit), cmp_ray_hit);
    CHECK(hbp_raycast_closest(bp, o, d, max_t, &h, &t, &found) == HBP_OK, "%s", hbp_last_error());
    CHECK(found == (n > 0), "step %u: found %d, %zu hits expected", step, found, n);
    if (n > 0) {
      CHECK(h == want[0].h && t == want[0].t, "step %u: closest %u at %g, want %u at %g", step, h, (double)t,
            want[0].h, (double)want[0].t);
    } else {
      CHECK(h == HBP_INVALID_HANDLE && t == 0.0f, "step %u: no hit must give the invalid handle", step);
    }
    /* Box cast: every hit by (t, handle), then stopped early. */
    random_vec(d, 8.0f);
    n = 0;
    for (i = 0; i < live; ++i)
      if (cast_entry(&box, d, &live_box[i], &t)) want[n].t = t, want[n++].h = live_handle[i];
    qsort(want, n, sizeof(ray_hit), cmp_ray_hit);
    c.n = 0;
    c.stop_after = 0;
    CHECK(hbp_box_cast(bp, &box, d, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
    CHECK(calls == n && c.n == n, "step %u: cast %zu hits, want %zu", step, c.n, n);
    for (i = 0; i < n; ++i) CHECK(c.got[i] == want[i].h, "step %u: cast hit %zu is %u, want %u", step, i, c.got[i], want[i].h);
    if (n > 1) {
      c.n = 0;
      c.stop_after = 1 + rnd_below((unsigned)n - 1);
      CHECK(hbp_box_cast(bp, &box, d, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
      CHECK(calls == c.stop_after, "step %u: early out after %zu calls, want %zu", step, calls, c.stop_after);
    }
  }
  return 0;
}

static int run(unsigned steps, uint32_t threads) {
  hbp_broad_phase* bp;
  unsigned step;
  if (create_with_threads(threads, &bp)) return 1;
  live = 0;
  for (step = 0; step < steps; ++step) {
    unsigned r = rnd_below(8), i;
    if (live + 4 < MAX_LIVE && (live < 150 || r < 2)) {
      hbp_box boxes[4];
      hbp_handle hs[4];
      unsigned n = 1 + rnd_below(4), j;
      for (j = 0; j < n; ++j) boxes[j] = random_box();
      CHECK(hbp_add(bp, boxes, n, (int)(rnd_below(3) == 0), 0, hs) == HBP_OK, "%s", hbp_last_error());
      for (j = 0; j < n; ++j) live_handle[live] = hs[j], live_box[live++] = boxes[j];
    } else if (r == 2 && live > 0) {
      i = rnd_below((unsigned)live);
      CHECK(hbp_remove(bp, &live_handle[i], 1) == HBP_OK, "%s", hbp_last_error());
      live_handle[i] = live_handle[live - 1];
      live_box[i] = live_box[--live];
    }
    for (i = 0; i < live; ++i) {
      if (rnd_below(4) != 0) continue;
      live_box[i] = rnd_below(8) == 0 ? random_box() : live_box[i];
      live_box[i].min[i % 3] += 0.5f;
      live_box[i].max[i % 3] += 0.5f;
      CHECK(hbp_move(bp, &live_handle[i], &live_box[i], 1) == HBP_OK, "%s", hbp_last_error());
    }
    if (rnd_below(2)) CHECK(hbp_update(bp) == HBP_OK, "%s", hbp_last_error());
    if (check_queries(bp, step)) {
      hbp_destroy(bp);
      return 1;
    }
  }
  hbp_destroy(bp);
  return 0;
}

static int check_errors(void) {
  hbp_broad_phase* bp;
  hbp_box box = {{0, 0, 0}, {1, 1, 1}}, bad = {{1, 0, 0}, {0, 1, 1}};
  float o[3] = {0, 0, 0}, d[3] = {1, 0, 0}, nan_d[3] = {NAN, 0, 0}, t = 5.0f;
  hbp_handle h = 5;
  int found = 7;
  collector c;
  size_t calls = 9;
  c.n = 0;
  c.stop_after = 0;
  CHECK(hbp_create(NULL, &bp) == HBP_OK, "%s", hbp_last_error());
  CHECK(hbp_raycast_closest(NULL, o, d, 1.0f, &h, &t, &found) == HBP_ERROR_INVALID_ARGUMENT, "NULL bp accepted");
  CHECK(strstr(hbp_last_error(), "hbp_raycast_closest") != NULL, "%s", hbp_last_error());
  CHECK(hbp_raycast_closest(bp, o, d, 1.0f, NULL, &t, &found) == HBP_ERROR_INVALID_ARGUMENT, "NULL out accepted");
  CHECK(hbp_raycast_closest(bp, o, nan_d, 1.0f, &h, &t, &found) == HBP_ERROR_INVALID_ARGUMENT, "NaN accepted");
  CHECK(strstr(hbp_last_error(), "direction[0]") != NULL, "%s", hbp_last_error());
  CHECK(found == 0 && h == HBP_INVALID_HANDLE, "a failed call must say no hit");
  CHECK(hbp_raycast_closest(bp, o, d, -1.0f, &h, &t, &found) == HBP_ERROR_INVALID_ARGUMENT, "max_t < 0 accepted");
  CHECK(hbp_box_cast(bp, NULL, d, collect, &c, &calls) == HBP_ERROR_INVALID_ARGUMENT, "NULL box accepted");
  CHECK(calls == 0, "hits_out not reset");
  CHECK(hbp_box_cast(bp, &bad, d, collect, &c, &calls) == HBP_ERROR_INVALID_ARGUMENT, "bad box accepted");
  CHECK(strstr(hbp_last_error(), "box") != NULL, "%s", hbp_last_error());
  CHECK(hbp_box_cast(bp, &box, nan_d, collect, &c, &calls) == HBP_ERROR_INVALID_ARGUMENT, "NaN accepted");
  CHECK(strstr(hbp_last_error(), "displacement[0]") != NULL, "%s", hbp_last_error());
  CHECK(hbp_box_cast(bp, &box, d, collect, &c, &calls) == HBP_OK && calls == 0, "empty cast");
  CHECK(hbp_raycast_closest(bp, o, d, INFINITY, &h, &t, &found) == HBP_OK && found == 0, "empty ray");
  hbp_destroy(bp);
  return 0;
}

int main(int argc, char** argv) {
  const unsigned steps = seed_and_count(argc, argv, 2000u);
  if (check_errors()) return 1;
  return run_1_and_2_threads(run, steps);
}
