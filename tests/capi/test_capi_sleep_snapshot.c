/* SPDX-License-Identifier: MIT */
/*
 * hbp_set_static, hbp_snapshot_size / hbp_snapshot / hbp_restore from C99:
 * random add / move / remove / sleep / wake frames checked against a
 * brute-force oracle written here (pairs, created, removed every frame);
 * every few frames a snapshot is restored into a second broad phase and
 * both are driven alike for the next frames, which must match each other
 * and the oracle; plus the error cases (stale handle named by row, buffer
 * too small, malformed data leaving the object unchanged). Exits 0 when
 * everything matches; else prints the first difference and exits 1.
 *
 *   test_capi_sleep_snapshot [seed] [frames]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define MAX_LIVE 400

#define OK(call) CHECK((call) == HBP_OK, "%s", hbp_last_error())

static hbp_box random_box(void) { return grid_box(40, 7); }

/* ---- the oracle ---- */
typedef struct {
  hbp_handle handle;
  hbp_box box;
  int is_static;
} object;

static object live[MAX_LIVE];
static size_t live_count = 0;

static pair_list now_pairs, previous_pairs, want_created, want_removed;

static void oracle_pairs(pair_list* out) {
  size_t i, j;
  out->n = 0;
  for (i = 0; i < live_count; ++i)
    for (j = i + 1; j < live_count; ++j) {
      const object* a = &live[i];
      const object* b = &live[j];
      if ((a->is_static && b->is_static) || !overlaps(&a->box, &b->box)) continue;
      push_pair(out, ordered_pair(a->handle, b->handle));
    }
  qsort(out->v, out->n, sizeof(hbp_pair), cmp_pair);
}

/* ---- the same edits to every broad phase in bps[0 .. n_bps) and the oracle ---- */
static hbp_broad_phase* bps[2];
static size_t n_bps = 1;

static int add_some(size_t n, int is_static) {
  hbp_box boxes[16];
  hbp_handle h[16], first[16];
  size_t i, s;
  if (live_count + n > MAX_LIVE) return 0;
  for (i = 0; i < n; ++i) boxes[i] = random_box();
  for (s = 0; s < n_bps; ++s) {
    OK(hbp_add(bps[s], boxes, n, is_static, 0, h));
    if (s == 0) memcpy(first, h, n * sizeof(hbp_handle));
    for (i = 0; i < n; ++i) CHECK(h[i] == first[i], "add: broad phase %lu gave handle %u, the first %u", (unsigned long)s, h[i], first[i]);
  }
  for (i = 0; i < n; ++i) {
    live[live_count].handle = first[i];
    live[live_count].box = boxes[i];
    live[live_count].is_static = is_static;
    ++live_count;
  }
  return 0;
}

/* n distinct random live indices (a partial shuffle of 0 .. live_count-1). */
static size_t pick(size_t* idx, size_t n) {
  size_t i;
  static size_t order[MAX_LIVE];
  for (i = 0; i < live_count; ++i) order[i] = i;
  if (n > live_count) n = live_count;
  for (i = 0; i < n; ++i) {
    size_t j = i + rnd() % (live_count - i), t = order[i];
    order[i] = order[j];
    order[j] = t;
    idx[i] = order[i];
  }
  return n;
}

static int edit(void) {
  size_t idx[MAX_LIVE], n, i, s;
  hbp_handle h[MAX_LIVE];
  hbp_box b[MAX_LIVE];
  switch (rnd() % 6) {
    case 0:
      return add_some(1 + rnd() % 8, rnd() % 3 == 0);
    case 1: /* remove, keeping the order of the rest irrelevant (the oracle sorts pairs) */
      n = pick(idx, rnd() % 6);
      for (i = 0; i < n; ++i) h[i] = live[idx[i]].handle;
      for (s = 0; s < n_bps; ++s) OK(hbp_remove(bps[s], h, n));
      for (i = 0; i < n; ++i) live[idx[i]].handle = HBP_INVALID_HANDLE;
      for (i = 0, s = 0; i < live_count; ++i)
        if (live[i].handle != HBP_INVALID_HANDLE) live[s++] = live[i];
      live_count = s;
      return 0;
    case 2:
    case 3: { /* sleep or wake a batch of either kind */
      const int to_static = (int)(rnd() % 2);
      n = pick(idx, 1 + rnd() % 30);
      for (i = 0; i < n; ++i) h[i] = live[idx[i]].handle;
      for (s = 0; s < n_bps; ++s) OK(hbp_set_static(bps[s], h, n, to_static));
      for (i = 0; i < n; ++i) live[idx[i]].is_static = to_static;
      return 0;
    }
    default: /* nudge moving objects */
      n = pick(idx, live_count / 3);
      for (i = 0; i < n; ++i) {
        int k;
        h[i] = live[idx[i]].handle;
        b[i] = live[idx[i]].box;
        for (k = 0; k < 3; ++k) {
          const float d = 0.5f * (float)((int)(rnd() % 5) - 2);
          b[i].min[k] += d;
          b[i].max[k] += d;
        }
      }
      for (s = 0; s < n_bps; ++s) OK(hbp_move(bps[s], h, b, n));
      for (i = 0; i < n; ++i) live[idx[i]].box = b[i];
      return 0;
  }
}

static int frame_and_check(unsigned frame) {
  size_t s;
  oracle_pairs(&now_pairs);
  difference(&now_pairs, &previous_pairs, &want_created);
  difference(&previous_pairs, &now_pairs, &want_removed);
  for (s = 0; s < n_bps; ++s) {
    const hbp_pair* p;
    size_t n;
    OK(hbp_update(bps[s]));
    OK(hbp_pairs(bps[s], &p, &n));
    if (same_pairs("pairs", frame, p, n, &now_pairs)) return 1;
    OK(hbp_created_pairs(bps[s], &p, &n));
    if (same_pairs("created", frame, p, n, &want_created)) return 1;
    OK(hbp_removed_pairs(bps[s], &p, &n));
    if (same_pairs("removed", frame, p, n, &want_removed)) return 1;
  }
  { /* this frame's pairs become the previous ones; the old list is reused */
    const pair_list t = previous_pairs;
    previous_pairs = now_pairs;
    now_pairs = t;
  }
  return 0;
}

static unsigned char* take_snapshot(hbp_broad_phase* bp, size_t* size) {
  unsigned char* buf;
  size_t need = 0, got = 0;
  if (hbp_snapshot_size(bp, &need) != HBP_OK) return NULL;
  buf = (unsigned char*)malloc(need);
  if (!buf) return NULL;
  if (hbp_snapshot(bp, buf, need, &got) != HBP_OK || got != need) {
    free(buf);
    return NULL;
  }
  *size = need;
  return buf;
}

static int errors(void) {
  hbp_broad_phase* bp;
  hbp_box box = {{0, 0, 0}, {1, 1, 1}};
  hbp_handle h[3];
  unsigned char small[16];
  unsigned char* snap;
  unsigned char* again;
  size_t size = 0, size2 = 0, got = 12345;
  OK(hbp_create(NULL, &bp));
  OK(hbp_add(bp, &box, 1, 0, 0, &h[0]));
  OK(hbp_add(bp, &box, 1, 0, 0, &h[1]));
  OK(hbp_remove(bp, &h[1], 1));
  OK(hbp_update(bp));
  h[2] = h[0];
  CHECK(hbp_set_static(bp, h, 2, 1) == HBP_ERROR_INVALID_ARGUMENT, "stale handle accepted");
  CHECK(strstr(hbp_last_error(), "set_static: row 1") != NULL, "%s", hbp_last_error());
  CHECK(hbp_set_static(NULL, h, 1, 1) == HBP_ERROR_INVALID_ARGUMENT, "NULL bp accepted");
  CHECK(hbp_set_static(bp, NULL, 1, 1) == HBP_ERROR_INVALID_ARGUMENT, "NULL handles accepted");
  OK(hbp_set_static(bp, NULL, 0, 1));

  snap = take_snapshot(bp, &size);
  CHECK(snap != NULL, "snapshot: %s", hbp_last_error());
  CHECK(hbp_snapshot(bp, small, sizeof small, &got) == HBP_ERROR_CAPACITY, "a small buffer accepted");
  CHECK(got == size, "size_out %lu, snapshot %lu", (unsigned long)got, (unsigned long)size);
  CHECK(hbp_snapshot(bp, NULL, 0, &got) == HBP_ERROR_CAPACITY, "no buffer accepted");
  CHECK(hbp_snapshot(bp, NULL, 5, &got) == HBP_ERROR_INVALID_ARGUMENT, "NULL buffer accepted");
  CHECK(hbp_snapshot_size(bp, NULL) == HBP_ERROR_INVALID_ARGUMENT, "NULL size_out accepted");

  /* Malformed data: an error naming it, and bp unchanged. */
  CHECK(hbp_restore(bp, snap, size - 1) == HBP_ERROR_INVALID_ARGUMENT, "truncated data accepted");
  CHECK(strstr(hbp_last_error(), "truncated") != NULL, "%s", hbp_last_error());
  snap[size - 3] ^= 0x10;
  CHECK(hbp_restore(bp, snap, size) == HBP_ERROR_INVALID_ARGUMENT, "corrupted data accepted");
  CHECK(strstr(hbp_last_error(), "checksum") != NULL, "%s", hbp_last_error());
  snap[size - 3] ^= 0x10;
  CHECK(hbp_restore(bp, NULL, 0) == HBP_ERROR_INVALID_ARGUMENT, "no data accepted");
  CHECK(hbp_restore(bp, NULL, 4) == HBP_ERROR_INVALID_ARGUMENT, "NULL data accepted");
  again = take_snapshot(bp, &size2);
  CHECK(again != NULL && size2 == size && memcmp(again, snap, size) == 0, "a failed restore changed the object");
  OK(hbp_restore(bp, snap, size));
  CHECK(hbp_contains(bp, h[0]) && !hbp_contains(bp, h[1]), "restored handles");
  free(snap);
  free(again);
  hbp_destroy(bp);
  return 0;
}

int main(int argc, char** argv) {
  const unsigned frames = seed_and_count(argc, argv, 600);
  unsigned f, restores = 0, follow = 0;
  hbp_options o;
  if (errors()) return 1;
  hbp_options_init(&o);
  o.threads = 2;
  if (hbp_create(&o, &bps[0]) != HBP_OK) return 1;
  if (add_some(16, 0) || add_some(16, 0) || add_some(8, 1)) return 1;
  for (f = 0; f < frames; ++f) {
    unsigned e, edits = 1 + rnd() % 3;
    for (e = 0; e < edits; ++e)
      if (edit()) return 1;
    if (follow == 0 && f % 50 == 25) { /* a snapshot mid-frame, restored into a second broad phase */
      size_t size = 0;
      unsigned char* snap = take_snapshot(bps[0], &size);
      CHECK(snap != NULL, "snapshot: %s", hbp_last_error());
      o.threads = 1;
      OK(hbp_create(&o, &bps[1]));
      OK(hbp_restore(bps[1], snap, size));
      free(snap);
      n_bps = 2;
      follow = 100;
      ++restores;
    }
    if (edit() || frame_and_check(f)) return 1;
    if (follow > 0 && --follow == 0) {
      hbp_destroy(bps[1]);
      n_bps = 1;
    }
  }
  if (n_bps == 2) hbp_destroy(bps[1]);
  hbp_destroy(bps[0]);
  CHECK(restores > 0, "no restore");
  printf("ok: %u frames, %u restores\n", frames, restores);
  return 0;
}
