/* SPDX-License-Identifier: MIT */
/*
 * The C API (hbp/hbp.h) from C99: random add / move / remove / set_collides
 * sequences, every frame's pairs, created and removed pairs checked against
 * a brute-force oracle written here, box and ray queries (with early-out)
 * against the oracle, and the error cases. Exits 0 when everything matches;
 * else prints the first difference and exits 1.
 *
 *   test_capi [seed] [frames]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define MAX_LIVE 1200
#define LAYERS 4

static hbp_box random_box(void) { return grid_box(60, 9); }

/* ---- the oracle: what the broad phase holds ---- */
typedef struct {
  hbp_handle handle;
  hbp_box box;
  int is_static;
  unsigned layer;
} object;

static object live[MAX_LIVE];
static size_t live_count = 0;
static int collides[HBP_LAYER_COUNT][HBP_LAYER_COUNT];

static void oracle_pairs(pair_list* out) {
  size_t i, j;
  out->n = 0;
  for (i = 0; i < live_count; ++i) {
    for (j = i + 1; j < live_count; ++j) {
      const object* a = &live[i];
      const object* b = &live[j];
      if (a->is_static && b->is_static) continue;
      if (!collides[a->layer][b->layer]) continue;
      if (!overlaps(&a->box, &b->box)) continue;
      push_pair(out, ordered_pair(a->handle, b->handle));
    }
  }
  qsort(out->v, out->n, sizeof(hbp_pair), cmp_pair);
}

/* ---- queries ---- */
typedef struct {
  hbp_handle got[MAX_LIVE];
  size_t n;
  size_t stop_after; /* 0: never stop */
} collector;

static int collect(void* user, hbp_handle h) {
  collector* c = (collector*)user;
  c->got[c->n++] = h;
  return !(c->stop_after != 0 && c->n >= c->stop_after);
}


static size_t box_hits = 0, ray_hits = 0;

static int check_queries(hbp_broad_phase* bp, unsigned frame) {
  static collector c;
  static hbp_handle want[MAX_LIVE];
  static ray_hit hits[MAX_LIVE];
  int q;
  for (q = 0; q < 6; ++q) {
    hbp_box box = random_box();
    size_t n = 0, i, calls = 0;
    box.max[q % 3] += 10.0f;
    for (i = 0; i < live_count; ++i) {
      if (overlaps(&box, &live[i].box)) want[n++] = live[i].handle;
    }
    qsort(want, n, sizeof(hbp_handle), cmp_handle);
    c.n = 0;
    c.stop_after = 0;
    CHECK(hbp_query_box(bp, &box, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
    CHECK(c.n == n && calls == n, "frame %u: box query: %lu hits, oracle %lu", frame, (unsigned long)c.n,
          (unsigned long)n);
    for (i = 0; i < n; ++i) CHECK(c.got[i] == want[i], "frame %u: box query hit %lu", frame, (unsigned long)i);
    box_hits += n;
    /* early-out: the callback returns 0 at the second hit */
    c.n = 0;
    c.stop_after = 2;
    CHECK(hbp_query_box(bp, &box, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
    CHECK(calls == (n < 2 ? n : 2) && c.n == calls, "frame %u: early-out after %lu calls of %lu hits", frame,
          (unsigned long)calls, (unsigned long)n);
    for (i = 0; i < calls; ++i) CHECK(c.got[i] == want[i], "frame %u: early-out hit %lu", frame, (unsigned long)i);
  }
  for (q = 0; q < 6; ++q) {
    float o[3], d[3];
    float max_t = (q % 2) ? INFINITY : 0.5f * (float)(1 + rnd_below(60));
    size_t n = 0, i, calls = 0;
    int k;
    for (k = 0; k < 3; ++k) {
      o[k] = 0.25f * (float)rnd_below(120);
      d[k] = (float)((int)rnd_below(9) - 4) * 0.5f; /* zero components too */
    }
    if (q == 0) d[0] = d[1] = 0.0f; /* a ray along z */
    for (i = 0; i < live_count; ++i) {
      float t;
      if (ray_entry(o, d, max_t, live[i].box.min, live[i].box.max, &t)) {
        hits[n].t = t;
        hits[n].h = live[i].handle;
        ++n;
      }
    }
    qsort(hits, n, sizeof(ray_hit), cmp_ray_hit);
    ray_hits += n;
    c.n = 0;
    c.stop_after = 0;
    CHECK(hbp_query_ray(bp, o, d, max_t, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
    CHECK(c.n == n && calls == n, "frame %u: ray query: %lu hits, oracle %lu", frame, (unsigned long)c.n,
          (unsigned long)n);
    for (i = 0; i < n; ++i) {
      CHECK(c.got[i] == hits[i].h, "frame %u: ray hit %lu is %u, oracle %u (t %g)", frame, (unsigned long)i,
            c.got[i], hits[i].h, (double)hits[i].t);
    }
    c.n = 0;
    c.stop_after = 1;
    CHECK(hbp_query_ray(bp, o, d, max_t, collect, &c, &calls) == HBP_OK, "%s", hbp_last_error());
    CHECK(calls == (n < 1 ? n : 1), "frame %u: ray early-out after %lu calls", frame, (unsigned long)calls);
  }
  return 0;
}

static size_t find_live(hbp_handle h) {
  size_t i;
  for (i = 0; i < live_count; ++i) {
    if (live[i].handle == h) return i;
  }
  return (size_t)-1;
}

/* ---- the random sequence ---- */
static int run_frames(unsigned frames, uint32_t threads) {
  hbp_broad_phase* bp = NULL;
  hbp_options options;
  pair_list now = {0, 0, 0}, before = {0, 0, 0}, want = {0, 0, 0};
  unsigned frame, a, b;
  size_t total_pairs = 0, total_created = 0, total_removed = 0;

  hbp_options_init(&options);
  options.threads = threads;
  CHECK(hbp_create(&options, &bp) == HBP_OK && bp != NULL, "hbp_create: %s", hbp_last_error());
  for (a = 0; a < HBP_LAYER_COUNT; ++a)
    for (b = 0; b < HBP_LAYER_COUNT; ++b) collides[a][b] = 1;
  live_count = 0;

  for (frame = 0; frame < frames; ++frame) {
    hbp_box boxes[128];
    hbp_handle handles[128];
    size_t i, k, n;
    /* add a batch */
    n = live_count + 128 <= MAX_LIVE ? (size_t)(frame == 0 ? 128 : rnd_below(40)) : 0;
    if (n > 0) {
      int is_static = (int)(rnd_below(4) == 0);
      uint8_t layer = (uint8_t)rnd_below(LAYERS);
      for (i = 0; i < n; ++i) boxes[i] = random_box();
      CHECK(hbp_add(bp, boxes, n, is_static, layer, handles) == HBP_OK, "hbp_add: %s", hbp_last_error());
      for (i = 0; i < n; ++i) {
        live[live_count].handle = handles[i];
        live[live_count].box = boxes[i];
        live[live_count].is_static = is_static;
        live[live_count].layer = layer;
        ++live_count;
      }
    }
    /* move a batch (distinct objects, static ones too) */
    n = live_count < 60 ? live_count / 2 : 30;
    for (i = 0, k = rnd_below((unsigned)live_count + 1); i < n; ++i) {
      size_t at = (k + i) % live_count; /* n <= live_count: distinct */
      handles[i] = live[at].handle;
      boxes[i] = random_box();
    }
    if (n > 0) {
      CHECK(hbp_move(bp, handles, boxes, n) == HBP_OK, "hbp_move: %s", hbp_last_error());
      for (i = 0; i < n; ++i) live[find_live(handles[i])].box = boxes[i];
    }
    /* remove a batch */
    n = live_count > 40 ? rnd_below(25) : 0;
    for (i = 0; i < n; ++i) handles[i] = live[(i * 13 + frame) % live_count].handle;
    qsort(handles, n, sizeof(hbp_handle), cmp_handle);
    for (i = 0, k = 0; i < n; ++i) { /* distinct */
      if (k == 0 || handles[k - 1] != handles[i]) handles[k++] = handles[i];
    }
    n = k;
    if (n > 0) {
      CHECK(hbp_remove(bp, handles, n) == HBP_OK, "hbp_remove: %s", hbp_last_error());
      for (i = 0; i < n; ++i) {
        size_t at = find_live(handles[i]);
        live[at] = live[--live_count];
        CHECK(!hbp_contains(bp, handles[i]), "removed handle %u still contained", handles[i]);
      }
    }
    /* the layer table, now and then */
    if (frame % 5 == 4) {
      unsigned la = rnd_below(LAYERS), lb = rnd_below(LAYERS);
      int c = (int)rnd_below(2);
      CHECK(hbp_set_collides(bp, la, lb, c) == HBP_OK, "%s", hbp_last_error());
      collides[la][lb] = collides[lb][la] = c;
    }

    CHECK(hbp_update(bp) == HBP_OK, "hbp_update: %s", hbp_last_error());
    {
      const hbp_pair* got;
      size_t count, size;
      oracle_pairs(&now);
      CHECK(hbp_pairs(bp, &got, &count) == HBP_OK, "%s", hbp_last_error());
      if (same_pairs("pairs", frame, got, count, &now)) return 1;
      total_pairs += count;
      difference(&now, &before, &want);
      CHECK(hbp_created_pairs(bp, &got, &count) == HBP_OK, "%s", hbp_last_error());
      if (same_pairs("created", frame, got, count, &want)) return 1;
      total_created += count;
      difference(&before, &now, &want);
      CHECK(hbp_removed_pairs(bp, &got, &count) == HBP_OK, "%s", hbp_last_error());
      if (same_pairs("removed", frame, got, count, &want)) return 1;
      total_removed += count;
      CHECK(hbp_size(bp, &size) == HBP_OK && size == live_count, "size %lu, oracle %lu", (unsigned long)size,
            (unsigned long)live_count);
    }
    if (check_queries(bp, frame)) return 1;
    {
      pair_list t = before;
      before = now;
      now = t;
    }
  }
  /* the sequence must have exercised something */
  CHECK(total_pairs > 20 * frames && total_created > 10 * frames && total_removed > 10 * frames &&
            box_hits > 5 * frames && ray_hits > 2 * frames, "too easy: %lu pairs, %lu created, %lu removed, %lu box and %lu ray hits",
        (unsigned long)total_pairs, (unsigned long)total_created, (unsigned long)total_removed,
        (unsigned long)box_hits, (unsigned long)ray_hits);
  printf("test_capi: %u frames on %u thread(s): %lu pairs, %lu created, %lu removed, %lu box and %lu ray hits, "
         "all as the oracle\n", frames, (unsigned)threads, (unsigned long)total_pairs, (unsigned long)total_created,
         (unsigned long)total_removed, (unsigned long)box_hits, (unsigned long)ray_hits);
  box_hits = ray_hits = 0;
  hbp_destroy(bp);
  free(now.v);
  free(before.v);
  free(want.v);
  return 0;
}

/* ---- errors: a status, a message naming the culprit, nothing applied ---- */
static int check_errors(void) {
  hbp_broad_phase* bp = NULL;
  hbp_options options;
  hbp_box boxes[4];
  hbp_handle h[4], gone;
  hbp_box got;
  size_t size, i;
  const hbp_pair* pairs;

  CHECK(strcmp(hbp_version(), "") != 0, "empty version");
  CHECK(strcmp(hbp_status_string(HBP_ERROR_CAPACITY), "capacity exceeded") == 0, "%s",
        hbp_status_string(HBP_ERROR_CAPACITY));

  hbp_options_init(&options);
  options.engine = "no-such-engine";
  CHECK(hbp_create(&options, &bp) == HBP_ERROR_INVALID_ARGUMENT && bp == NULL, "unknown engine accepted");
  CHECK(strstr(hbp_last_error(), "no-such-engine") != NULL, "message does not name the engine: %s", hbp_last_error());
  CHECK(hbp_create(NULL, NULL) == HBP_ERROR_INVALID_ARGUMENT, "NULL out accepted");
  CHECK(hbp_update(NULL) == HBP_ERROR_INVALID_ARGUMENT, "NULL bp accepted");

  hbp_options_init(&options);
  options.threads = 1;
  options.max_pairs = 2;
  CHECK(hbp_create(&options, &bp) == HBP_OK, "%s", hbp_last_error());
  CHECK(strcmp(hbp_last_error(), "") == 0, "a successful call leaves a message: %s", hbp_last_error());
  for (i = 0; i < 4; ++i) {
    int k;
    for (k = 0; k < 3; ++k) {
      boxes[i].min[k] = (float)i;
      boxes[i].max[k] = (float)i + 1.0f; /* each touches the next: 3 pairs */
    }
  }
  boxes[2].min[1] = NAN;
  CHECK(hbp_add(bp, boxes, 4, 0, 0, h) == HBP_ERROR_INVALID_ARGUMENT, "a NaN box accepted");
  CHECK(strstr(hbp_last_error(), "2") != NULL, "message does not name row 2: %s", hbp_last_error());
  CHECK(hbp_size(bp, &size) == HBP_OK && size == 0, "a rejected batch added %lu objects", (unsigned long)size);
  boxes[2].min[1] = 2.0f;
  CHECK(hbp_add(bp, boxes, 2, 0, HBP_LAYER_COUNT, h) == HBP_ERROR_INVALID_ARGUMENT, "layer 32 accepted");
  CHECK(hbp_add(bp, boxes, 4, 0, 0, h) == HBP_OK, "%s", hbp_last_error());

  /* 3 pairs > max_pairs 2: capacity, nothing applied */
  CHECK(hbp_update(bp) == HBP_ERROR_CAPACITY, "max_pairs not enforced");
  CHECK(strlen(hbp_last_error()) > 0, "no message for capacity");
  CHECK(hbp_pairs(bp, &pairs, &size) == HBP_OK && size == 0, "a failed update left %lu pairs", (unsigned long)size);
  /* move box 3 away: 2 pairs, which fit */
  boxes[3].min[0] = boxes[3].max[0] = 50.0f;
  CHECK(hbp_move(bp, &h[3], &boxes[3], 1) == HBP_OK, "%s", hbp_last_error());
  CHECK(hbp_update(bp) == HBP_OK, "%s", hbp_last_error());
  CHECK(hbp_created_pairs(bp, &pairs, &size) == HBP_OK && size == 2 && pairs[0].a == h[0] && pairs[0].b == h[1] &&
            pairs[1].a == h[1] && pairs[1].b == h[2],
        "after the capacity error: %lu created pairs", (unsigned long)size);

  /* stale handles, duplicates, NULL arrays */
  gone = h[3];
  CHECK(hbp_remove(bp, &gone, 1) == HBP_OK, "%s", hbp_last_error());
  CHECK(hbp_remove(bp, &gone, 1) == HBP_ERROR_INVALID_ARGUMENT, "a removed handle removed again");
  CHECK(hbp_move(bp, &gone, &boxes[0], 1) == HBP_ERROR_INVALID_ARGUMENT, "a removed handle moved");
  CHECK(hbp_get_box(bp, gone, &got) == HBP_ERROR_INVALID_ARGUMENT, "a removed handle's box read");
  CHECK(strlen(hbp_last_error()) > 0, "no message for a stale handle");
  {
    hbp_handle twice[2];
    twice[0] = h[0];
    twice[1] = h[0];
    CHECK(hbp_remove(bp, twice, 2) == HBP_ERROR_INVALID_ARGUMENT, "a handle removed twice in one batch");
    CHECK(hbp_contains(bp, h[0]), "a rejected remove removed %u", h[0]);
  }
  CHECK(hbp_move(bp, NULL, boxes, 1) == HBP_ERROR_INVALID_ARGUMENT, "NULL handles accepted");
  CHECK(hbp_add(bp, NULL, 0, 0, 0, NULL) == HBP_OK, "an empty batch refused: %s", hbp_last_error());
  CHECK(hbp_get_box(bp, h[1], &got) == HBP_OK && got.min[0] == 1.0f && got.max[2] == 2.0f, "box of h[1]");
  {
    float o[3] = {0, 0, 0}, d[3] = {1, 0, 0};
    collector c;
    c.n = 0;
    c.stop_after = 0;
    CHECK(hbp_query_ray(bp, o, d, -1.0f, collect, &c, NULL) == HBP_ERROR_INVALID_ARGUMENT, "max_t < 0 accepted");
    CHECK(strstr(hbp_last_error(), "max_t") != NULL, "message does not name max_t: %s", hbp_last_error());
    CHECK(hbp_query_box(bp, &boxes[0], NULL, NULL, NULL) == HBP_ERROR_INVALID_ARGUMENT, "NULL callback accepted");
  }
  hbp_destroy(bp);
  hbp_destroy(NULL);
  printf("test_capi: error cases OK\n");
  return 0;
}

int main(int argc, char** argv) {
  unsigned frames = 40;
  if (argc > 1) rng_state = strtoull(argv[1], NULL, 10) * 2654435761ull + 1;
  if (argc > 2) frames = (unsigned)strtoul(argv[2], NULL, 10);
  if (check_errors()) return 1;
  if (run_frames(frames, 1)) return 1;
  if (run_frames(frames, 2)) return 1;
  return check_failures == 0 ? 0 : 1;
}
