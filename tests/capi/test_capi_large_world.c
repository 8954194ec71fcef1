/* SPDX-License-Identifier: MIT */
/*
 * The C API's large-world calls from C99: a double-precision broad phase at
 * 1e8 (hbp_add_d, hbp_move_d, hbp_get_box_d, hbp_query_box_d) checked
 * against a brute force on the doubles every frame, with boxes a sub-float
 * gap apart and exactly touching; hbp_shift_origin on a float and a double
 * broad phase; the error cases. Exits 0 when everything matches.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define N 120
#define FRAMES 400

static int overlaps_d(const hbp_box_d* a, const hbp_box_d* b) {
  int k;
  for (k = 0; k < 3; ++k)
    if (a->max[k] < b->min[k] || a->min[k] > b->max[k]) return 0;
  return 1;
}

static hbp_box_d random_box(double centre) {
  hbp_box_d b;
  int k;
  for (k = 0; k < 3; ++k) {
    b.min[k] = centre + (rnd_unit() - 0.5) * 40.0;
    b.max[k] = b.min[k] + 0.01 + rnd_unit() * 5.0;
  }
  return b;
}

static int count_hit(void* user, hbp_handle h) {
  (void)h;
  ++*(size_t*)user;
  return 1;
}

int main(void) {
  const double centre = 1e8;
  hbp_options o;
  hbp_broad_phase* bp;
  hbp_box_d boxes[N];
  hbp_handle h[N];
  hbp_box fbox = {{0, 0, 0}, {1, 1, 1}};
  hbp_handle fh;
  int i, j, f;

  hbp_options_init(&o);
  CHECK(o.double_precision == 0, "default");
  o.threads = 2;
  o.double_precision = 1;
  CHECK(hbp_create(&o, &bp) == HBP_OK, "%s", hbp_last_error());
  for (i = 0; i < N; ++i) boxes[i] = random_box(centre);
  CHECK(hbp_add_d(bp, boxes, N / 4, 1, 0, h) == HBP_OK, "%s", hbp_last_error());
  CHECK(hbp_add_d(bp, boxes + N / 4, N - N / 4, 0, 0, h + N / 4) == HBP_OK, "%s", hbp_last_error());
  for (f = 0; f < FRAMES; ++f) {
    const hbp_pair* pairs;
    size_t count, want = 0, k = 0;
    hbp_handle mh[8];
    hbp_box_d mb[8];
    int m = 0;
    for (i = N / 4 + f % 8; i < N && m < 8; i += 11, ++m) {
      hbp_box_d b = boxes[i];
      if (m % 3 == 0) { /* against another box: touching, or 1e-6 apart (one box in float) */
        const hbp_box_d* other = &boxes[(i * 7 + f) % N];
        const double side = b.max[0] - b.min[0];
        b.min[0] = other->max[0] + (f % 2 ? 1e-6 : 0.0);
        b.max[0] = b.min[0] + side;
        for (j = 1; j < 3; ++j) {
          const double s = b.max[j] - b.min[j];
          b.min[j] = other->min[j];
          b.max[j] = other->min[j] + s;
        }
      } else {
        for (j = 0; j < 3; ++j) {
          const double d = rnd_unit() - 0.5;
          b.min[j] += d;
          b.max[j] += d;
        }
      }
      mh[m] = h[i];
      mb[m] = b;
      boxes[i] = b;
    }
    CHECK(hbp_move_d(bp, mh, mb, (size_t)m) == HBP_OK, "%s", hbp_last_error());
    CHECK(hbp_update(bp) == HBP_OK, "%s", hbp_last_error());
    CHECK(hbp_pairs(bp, &pairs, &count) == HBP_OK, "%s", hbp_last_error());
    for (i = 0; i < N; ++i)
      for (j = i + 1; j < N; ++j) {
        if (i < N / 4 && j < N / 4) continue;
        if (!overlaps_d(&boxes[i], &boxes[j])) continue;
        ++want;
        /* handles follow the rows here: pairs come in row order */
        CHECK(k < count && pairs[k].a == h[i] && pairs[k].b == h[j], "frame %d pair %u-%u", f, h[i], h[j]);
        ++k;
      }
    CHECK(count == want, "frame %d: %lu pairs, want %lu", f, (unsigned long)count, (unsigned long)want);
  }
  {
    hbp_box_d got;
    size_t hits = 0, want = 0;
    hbp_box_d q = random_box(centre);
    CHECK(hbp_get_box_d(bp, h[5], &got) == HBP_OK && memcmp(&got, &boxes[5], sizeof got) == 0, "get_box_d");
    CHECK(hbp_query_box_d(bp, &q, count_hit, &hits, NULL) == HBP_OK, "%s", hbp_last_error());
    for (i = 0; i < N; ++i) want += (size_t)overlaps_d(&boxes[i], &q);
    CHECK(hits == want, "query_box_d %lu, want %lu", (unsigned long)hits, (unsigned long)want);
  }
  {
    /* A power-of-two shift near the boxes is exact in double: no events. */
    const double offset[3] = {134217728.0, 134217728.0, 134217728.0};
    const hbp_pair* pairs;
    size_t count;
    hbp_box_d got;
    CHECK(hbp_shift_origin(bp, offset) == HBP_OK, "%s", hbp_last_error());
    CHECK(hbp_update(bp) == HBP_OK, "%s", hbp_last_error());
    CHECK(hbp_created_pairs(bp, &pairs, &count) == HBP_OK && count == 0, "created after an exact shift");
    CHECK(hbp_removed_pairs(bp, &pairs, &count) == HBP_OK && count == 0, "removed after an exact shift");
    CHECK(hbp_get_box_d(bp, h[5], &got) == HBP_OK && got.min[0] == boxes[5].min[0] - offset[0], "shifted box");
  }
  /* Errors: float calls on a double broad phase, non-finite offsets. */
  CHECK(hbp_add(bp, &fbox, 1, 0, 0, &fh) == HBP_ERROR_INVALID_ARGUMENT, "float add on double");
  CHECK(strstr(hbp_last_error(), "AabbD") != NULL, "%s", hbp_last_error());
  {
    const double bad[3] = {0, NAN, 0};
    hbp_box_d nan_box = {{0, 0, 0}, {1, 1, 1}};
    hbp_handle nh;
    CHECK(hbp_shift_origin(bp, bad) == HBP_ERROR_INVALID_ARGUMENT, "NaN offset");
    nan_box.max[2] = NAN;
    CHECK(hbp_add_d(bp, &nan_box, 1, 0, 0, &nh) == HBP_ERROR_INVALID_ARGUMENT, "NaN box");
    CHECK(hbp_shift_origin(NULL, bad) == HBP_ERROR_INVALID_ARGUMENT, "NULL bp");
  }
  hbp_destroy(bp);

  /* A float broad phase: shift_origin re-bases the float boxes; the _d calls are errors. */
  o.double_precision = 0;
  CHECK(hbp_create(&o, &bp) == HBP_OK, "%s", hbp_last_error());
  {
    hbp_box a = {{1000.25f, 0, 0}, {1001.5f, 1, 1}}, b = {{1001.5f, 0, 0}, {1002, 1, 1}}, got;
    hbp_handle ha, hb;
    const hbp_pair* pairs;
    size_t count;
    const double offset[3] = {1000, 0, 0};
    hbp_box_d db = {{0, 0, 0}, {1, 1, 1}};
    CHECK(hbp_add(bp, &a, 1, 0, 0, &ha) == HBP_OK && hbp_add(bp, &b, 1, 1, 0, &hb) == HBP_OK, "add");
    CHECK(hbp_update(bp) == HBP_OK && hbp_pairs(bp, &pairs, &count) == HBP_OK && count == 1, "touching pair");
    CHECK(hbp_shift_origin(bp, offset) == HBP_OK, "%s", hbp_last_error());
    CHECK(hbp_update(bp) == HBP_OK && hbp_pairs(bp, &pairs, &count) == HBP_OK && count == 1, "pair kept");
    CHECK(hbp_created_pairs(bp, &pairs, &count) == HBP_OK && count == 0, "no event");
    CHECK(hbp_get_box(bp, hb, &got) == HBP_OK && got.min[0] == 1.5f && got.max[0] == 2.0f, "shifted float box");
    CHECK(hbp_add_d(bp, &db, 1, 0, 0, &ha) == HBP_ERROR_INVALID_ARGUMENT, "double add on float");
  }
  hbp_destroy(bp);
  printf("ok\n");
  return 0;
}
