/* SPDX-License-Identifier: MIT */
/*
 * hbp_set_margin and hbp_move_swept from C99 against an oracle written here
 * (stored box = given box grown by the margin; a swept move unions the
 * previous box, the last swept one given, with the new one): random adds,
 * margin changes, plain and swept moves and removes; every frame's pairs and
 * boxes compared; one and two threads; error cases. Exits 0 when all match.
 *
 *   test_capi_fast_movers [seed] [frames]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define MAX_LIVE 300

static hbp_box random_box(void) { return grid_box(30, 5); }
static hbp_box grown(hbp_box b, float m) {
  int k;
  for (k = 0; k < 3; ++k) {
    b.min[k] -= m;
    b.max[k] += m;
  }
  return b;
}
static hbp_box united(hbp_box a, const hbp_box* b) {
  int k;
  for (k = 0; k < 3; ++k) {
    if (b->min[k] < a.min[k]) a.min[k] = b->min[k];
    if (b->max[k] > a.max[k]) a.max[k] = b->max[k];
  }
  return a;
}

typedef struct {
  hbp_handle handle;
  hbp_box stored, end;
  int swept, is_static;
  float margin;
} object;
static object live[MAX_LIVE];
static size_t n_live = 0;
static hbp_pair want[MAX_LIVE * MAX_LIVE / 2];

static int run(unsigned frames, uint32_t threads) {
  static const float margins[4] = {0.0f, 0.0f, 0.25f, 1.5f};
  hbp_broad_phase* bp;
  unsigned frame;
  if (create_with_threads(threads, &bp)) return 1;
  n_live = 0;
  for (frame = 0; frame < frames; ++frame) {
    size_t i, j, n = 0, count;
    const hbp_pair* pairs;
    unsigned r = rnd_below(6);
    int swept = (int)rnd_below(2);
    if (n_live + 1 < MAX_LIVE && (n_live < 100 || r == 0)) {
      hbp_box b = random_box();
      object* ob = &live[n_live++];
      ob->is_static = (int)(rnd_below(4) == 0);
      CHECK(hbp_add(bp, &b, 1, ob->is_static, 0, &ob->handle) == HBP_OK, "%s", hbp_last_error());
      ob->swept = 0;
      ob->margin = 0.0f; /* margins come from hbp_set_margin, for the boxes given after it */
      ob->stored = b;
    }
    if (r == 1 && n_live > 0) {
      i = rnd_below((unsigned)n_live);
      CHECK(hbp_remove(bp, &live[i].handle, 1) == HBP_OK, "%s", hbp_last_error());
      live[i] = live[--n_live];
    }
    if (r == 2 && n_live > 0) {
      float m = margins[rnd_below(4)];
      i = rnd_below((unsigned)n_live);
      CHECK(hbp_set_margin(bp, &live[i].handle, 1, m) == HBP_OK, "%s", hbp_last_error());
      live[i].margin = m;
    }
    for (i = 0; i < n_live; ++i) {
      hbp_box b = random_box(), nb;
      if (rnd_below(live[i].is_static ? 20 : 3) != 0) continue;
      nb = grown(b, live[i].margin);
      if (swept) {
        CHECK(hbp_move_swept(bp, &live[i].handle, &b, 1) == HBP_OK, "%s", hbp_last_error());
        live[i].stored = united(live[i].swept ? live[i].end : live[i].stored, &nb);
        live[i].end = nb;
        live[i].swept = 1;
      } else {
        CHECK(hbp_move(bp, &live[i].handle, &b, 1) == HBP_OK, "%s", hbp_last_error());
        live[i].stored = nb;
        live[i].swept = 0;
      }
    }
    CHECK(hbp_update(bp) == HBP_OK, "%s", hbp_last_error());
    for (i = 0; i < n_live; ++i) {
      hbp_box b;
      CHECK(hbp_get_box(bp, live[i].handle, &b) == HBP_OK, "%s", hbp_last_error());
      CHECK(memcmp(&b, &live[i].stored, sizeof b) == 0, "frame %u: box of %u", frame, live[i].handle);
    }
    for (i = 0; i < n_live; ++i)
      for (j = i + 1; j < n_live; ++j) {
        if ((live[i].is_static && live[j].is_static) || !overlaps(&live[i].stored, &live[j].stored)) continue;
        want[n].a = live[i].handle < live[j].handle ? live[i].handle : live[j].handle;
        want[n++].b = live[i].handle < live[j].handle ? live[j].handle : live[i].handle;
      }
    qsort(want, n, sizeof(hbp_pair), cmp_pair);
    CHECK(hbp_pairs(bp, &pairs, &count) == HBP_OK, "%s", hbp_last_error());
    CHECK(count == n, "frame %u: %zu pairs, want %zu", frame, count, n);
    for (i = 0; i < n; ++i)
      CHECK(cmp_pair(&want[i], &pairs[i]) == 0, "frame %u: pair %zu is %u-%u", frame, i, pairs[i].a, pairs[i].b);
  }
  {
    hbp_box b = {{0, 0, 0}, {3e38f, 1, 1}};
    CHECK(n_live == 0 || hbp_set_margin(bp, &live[0].handle, 1, -1.0f) == HBP_ERROR_INVALID_ARGUMENT, "margin -1");
    CHECK(n_live == 0 || hbp_set_margin(bp, &live[0].handle, 1, NAN) == HBP_ERROR_INVALID_ARGUMENT, "margin NaN");
    CHECK(n_live == 0 || hbp_set_margin(bp, &live[0].handle, 1, 1e38f) == HBP_OK, "%s", hbp_last_error());
    CHECK(n_live == 0 || hbp_move_swept(bp, &live[0].handle, &b, 1) == HBP_ERROR_INVALID_ARGUMENT,
          "an infinite grown box accepted");
  }
  hbp_destroy(bp);
  return 0;
}

int main(int argc, char** argv) {
  return run_1_and_2_threads(run, seed_and_count(argc, argv, 1500u));
}
