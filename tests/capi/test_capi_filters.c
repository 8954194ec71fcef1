/* SPDX-License-Identifier: MIT */
/*
 * Object filters, user data and query filters through the C API (C99),
 * against a brute-force oracle written here: random adds, moves, removes,
 * hbp_set_filter / hbp_set_user_data batches and layer-table changes; every
 * frame's pairs, the created pairs' user data, and filtered box queries
 * compared; one and two threads. Exits 0 when everything matches.
 *
 *   test_capi_filters [seed] [frames]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define MAX_LIVE 400

static hbp_box random_box(void) { return grid_box(30, 6); }

static hbp_filter random_filter(void) {
  hbp_filter f;
  hbp_filter_init(&f);
  if (rnd_below(2)) return f;
  f.category = 1ull << rnd_below(3);
  f.mask = rnd_below(3) == 0 ? ~0ull : (unsigned long long)rnd_below(8);
  f.group = (int32_t)rnd_below(5) - 2;
  return f;
}

typedef struct {
  hbp_handle handle;
  hbp_box box;
  int is_static;
  unsigned layer;
  hbp_filter filter;
  uint64_t user;
} object;
static object live[MAX_LIVE];
static size_t n_live = 0;
static int collides[3][3];

static int should_collide(const hbp_filter* a, const hbp_filter* b) {
  if (a->group == b->group && a->group != 0) return a->group > 0;
  return (a->category & b->mask) != 0 && (b->category & a->mask) != 0;
}
static const object* find(hbp_handle h) {
  size_t i;
  for (i = 0; i < n_live; ++i)
    if (live[i].handle == h) return &live[i];
  return NULL;
}

typedef struct {
  hbp_handle got[MAX_LIVE];
  size_t n;
} collector;
static int collect(void* user, hbp_handle h) {
  collector* c = (collector*)user;
  c->got[c->n++] = h;
  return 1;
}

static hbp_pair want[MAX_LIVE * MAX_LIVE / 2];

static int check_frame(hbp_broad_phase* bp, unsigned frame) {
  size_t i, j, n = 0, count;
  const hbp_pair* pairs;
  static uint64_t ud[2 * MAX_LIVE * MAX_LIVE / 2];
  for (i = 0; i < n_live; ++i)
    for (j = i + 1; j < n_live; ++j) {
      const object *a = &live[i], *b = &live[j];
      if (a->is_static && b->is_static) continue;
      if (!overlaps(&a->box, &b->box) || !collides[a->layer][b->layer]) continue;
      if (!should_collide(&a->filter, &b->filter)) continue;
      want[n].a = a->handle < b->handle ? a->handle : b->handle;
      want[n++].b = a->handle < b->handle ? b->handle : a->handle;
    }
  qsort(want, n, sizeof(hbp_pair), cmp_pair);
  CHECK(hbp_update(bp) == HBP_OK, "%s", hbp_last_error());
  CHECK(hbp_pairs(bp, &pairs, &count) == HBP_OK, "%s", hbp_last_error());
  CHECK(count == n, "frame %u: %zu pairs, want %zu", frame, count, n);
  for (i = 0; i < n; ++i)
    CHECK(pairs[i].a == want[i].a && pairs[i].b == want[i].b, "frame %u: pair %zu differs", frame, i);
  CHECK(hbp_pair_user_data(bp, pairs, count, ud) == HBP_OK, "%s", hbp_last_error());
  for (i = 0; i < n; ++i)
    CHECK(ud[2 * i] == find(pairs[i].a)->user && ud[2 * i + 1] == find(pairs[i].b)->user,
          "frame %u: user data of pair %zu", frame, i);
  for (i = 0; i < n_live; ++i) {
    uint64_t v;
    hbp_filter f;
    CHECK(hbp_get_user_data(bp, live[i].handle, &v) == HBP_OK && v == live[i].user, "user data");
    CHECK(hbp_get_filter(bp, live[i].handle, &f) == HBP_OK && f.category == live[i].filter.category &&
              f.mask == live[i].filter.mask && f.group == live[i].filter.group,
          "filter read back");
  }
  {  /* a filtered box query */
    static collector c;
    static hbp_handle w[MAX_LIVE];
    hbp_query_filter q;
    hbp_box box = random_box();
    size_t m = 0, calls;
    hbp_query_filter_init(&q);
    q.layers_mask = rnd_below(2) ? 0xFFFFFFFFu : rnd_below(8);
    q.category_mask = rnd_below(2) ? ~0ull : (unsigned long long)rnd_below(8);
    for (i = 0; i < n_live; ++i)
      if (((q.layers_mask >> live[i].layer) & 1u) && (live[i].filter.category & q.category_mask) &&
          overlaps(&live[i].box, &box))
        w[m++] = live[i].handle;
    qsort(w, m, sizeof(hbp_handle), cmp_handle);
    c.n = 0;
    CHECK(hbp_query_box_filtered(bp, &box, &q, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
    CHECK(calls == m, "frame %u: filtered query %zu hits, want %zu", frame, calls, m);
    for (i = 0; i < m; ++i) CHECK(c.got[i] == w[i], "frame %u: filtered hit %zu", frame, i);
  }
  return 0;
}

static int run(unsigned frames, uint32_t threads) {
  hbp_broad_phase* bp;
  unsigned frame, a, b;
  if (create_with_threads(threads, &bp)) return 1;
  n_live = 0;
  for (a = 0; a < 3; ++a)
    for (b = 0; b < 3; ++b) collides[a][b] = 1;
  for (frame = 0; frame < frames; ++frame) {
    unsigned r = rnd_below(6), i;
    if (n_live + 4 < MAX_LIVE && (n_live < 120 || r == 0)) {
      hbp_box boxes[4];
      hbp_handle hs[4];
      unsigned n = 1 + rnd_below(4), j, layer = rnd_below(3);
      int is_static = (int)(rnd_below(3) == 0);
      for (j = 0; j < n; ++j) boxes[j] = random_box();
      CHECK(hbp_add(bp, boxes, n, is_static, (uint8_t)layer, hs) == HBP_OK, "%s", hbp_last_error());
      for (j = 0; j < n; ++j) {
        object* ob = &live[n_live++];
        ob->handle = hs[j];
        ob->box = boxes[j];
        ob->is_static = is_static;
        ob->layer = layer;
        hbp_filter_init(&ob->filter);
        ob->user = 0;
      }
    }
    if (r == 1 && n_live > 0) {
      i = rnd_below((unsigned)n_live);
      CHECK(hbp_remove(bp, &live[i].handle, 1) == HBP_OK, "%s", hbp_last_error());
      live[i] = live[--n_live];
    }
    if (r == 2 || r == 3) {  /* a filter for a few objects */
      hbp_handle hs[8];
      unsigned n = 0;
      hbp_filter f = random_filter();
      for (i = 0; i < n_live && n < 8; ++i)
        if (rnd_below(10) == 0) {
          hs[n++] = live[i].handle;
          live[i].filter = f;
        }
      CHECK(hbp_set_filter(bp, hs, n, &f) == HBP_OK, "%s", hbp_last_error());
    }
    if (r == 4) {  /* user data and the layer table */
      hbp_handle hs[8];
      uint64_t vs[8];
      unsigned n = 0, la = rnd_below(3), lb = rnd_below(3);
      int c = (int)rnd_below(2);
      for (i = 0; i < n_live && n < 8; ++i)
        if (rnd_below(10) == 0) {
          hs[n] = live[i].handle;
          vs[n] = ((uint64_t)rnd() << 32) | rnd();
          live[i].user = vs[n++];
        }
      CHECK(hbp_set_user_data(bp, hs, vs, n) == HBP_OK, "%s", hbp_last_error());
      CHECK(hbp_set_collides(bp, la, lb, c) == HBP_OK, "%s", hbp_last_error());
      collides[la][lb] = collides[lb][la] = c;
    }
    for (i = 0; i < n_live; ++i) {
      if (live[i].is_static || rnd_below(3) != 0) continue;
      live[i].box.min[i % 3] += 0.5f * ((float)rnd_below(3) - 1.0f);
      live[i].box.max[i % 3] = live[i].box.min[i % 3] + 0.5f * (float)rnd_below(6);
      CHECK(hbp_move(bp, &live[i].handle, &live[i].box, 1) == HBP_OK, "%s", hbp_last_error());
    }
    if (check_frame(bp, frame)) {
      hbp_destroy(bp);
      return 1;
    }
  }
  {  /* errors */
    hbp_handle stale = 0xFFFFFFu;
    uint64_t v = 1;
    CHECK(hbp_set_user_data(bp, &stale, &v, 1) == HBP_ERROR_INVALID_ARGUMENT, "stale handle accepted");
    CHECK(hbp_set_filter(bp, &stale, 1, NULL) == HBP_ERROR_INVALID_ARGUMENT, "NULL filter accepted");
    CHECK(hbp_get_user_data(bp, stale, &v) == HBP_ERROR_INVALID_ARGUMENT, "stale handle accepted");
  }
  hbp_destroy(bp);
  return 0;
}

int main(int argc, char** argv) {
  return run_1_and_2_threads(run, seed_and_count(argc, argv, 1500u));
}
