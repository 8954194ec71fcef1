/* SPDX-License-Identifier: MIT */
/*
 * The engine's job system through the C API (hbp_options.run_tasks): three
 * broad phases get the same random add / move / remove stream, one on the
 * library's own threads, one on a run_tasks that runs each batch on POSIX
 * threads of its own (tasks claimed from a shared counter), one on a
 * run_tasks that runs the tasks serially, last first, while claiming four
 * threads. Every frame's pairs, created and removed pairs must equal a
 * sweep-and-prune oracle written here, for all three. The callbacks check
 * the contract: called on the thread that called hbp_update (or an edit),
 * never while another batch runs. Exits 0 when everything matches.
 *
 *   test_capi_tasks [seed] [frames]
 */
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hbp/hbp.h"

#include "capi_check.h"

#define MAX_LIVE 30000
#define WORKERS 3

static float uniform(float lo, float hi) { return lo + (hi - lo) * (float)(rnd() % 1000000u) / 1000000.0f; }

/* ---- the engine's job systems ---- */

struct contract {
  pthread_t caller; /* the thread calling into the library */
  int in_batch;     /* a batch is running */
  int nested;       /* run_tasks entered while a batch ran */
  int foreign;      /* run_tasks called from another thread */
  long batches;
};

static void enter(struct contract* c) {
  if (c->in_batch) ++c->nested;
  if (!pthread_equal(pthread_self(), c->caller)) ++c->foreign;
  c->in_batch = 1;
  ++c->batches;
}

/* Serially, last task first. */
static void run_reverse(void* user, uint32_t count, hbp_task_fn task, void* context) {
  struct contract* c = (struct contract*)user;
  uint32_t i;
  enter(c);
  for (i = count; i-- > 0;) task(context, i);
  c->in_batch = 0;
}

/* On WORKERS threads started for the batch plus the caller. */
struct batch {
  pthread_mutex_t lock;
  uint32_t next, count;
  hbp_task_fn task;
  void* context;
};

static void* drain(void* arg) {
  struct batch* b = (struct batch*)arg;
  for (;;) {
    uint32_t k;
    pthread_mutex_lock(&b->lock);
    k = b->next < b->count ? b->next++ : b->count;
    pthread_mutex_unlock(&b->lock);
    if (k == b->count) return NULL;
    b->task(b->context, k);
  }
}

static void run_threads(void* user, uint32_t count, hbp_task_fn task, void* context) {
  struct contract* c = (struct contract*)user;
  struct batch b;
  pthread_t threads[WORKERS];
  int started[WORKERS];
  int w;
  enter(c);
  pthread_mutex_init(&b.lock, NULL);
  b.next = 0;
  b.count = count;
  b.task = task;
  b.context = context;
  for (w = 0; w < WORKERS; ++w) started[w] = pthread_create(&threads[w], NULL, drain, &b) == 0;
  drain(&b); /* (a thread that did not start leaves its share to the caller) */
  for (w = 0; w < WORKERS; ++w)
    if (started[w]) pthread_join(threads[w], NULL);
  pthread_mutex_destroy(&b.lock);
  c->in_batch = 0;
}

/* ---- the world and its oracle ---- */

static hbp_handle handles[MAX_LIVE];
static hbp_box boxes[MAX_LIVE];
static int statics[MAX_LIVE];
static size_t live = 0;

static hbp_box random_box(float side, float size) {
  hbp_box b;
  int k;
  for (k = 0; k < 3; ++k) {
    b.min[k] = uniform(0.0f, side);
    b.max[k] = b.min[k] + uniform(0.2f * size, size);
  }
  return b;
}

static int by_min_x(const void* x, const void* y) {
  const size_t i = *(const size_t*)x, j = *(const size_t*)y;
  if (boxes[i].min[0] != boxes[j].min[0]) return boxes[i].min[0] < boxes[j].min[0] ? -1 : 1;
  return i < j ? -1 : i > j;
}
static int by_pair(const void* x, const void* y) {
  const hbp_pair* p = (const hbp_pair*)x;
  const hbp_pair* q = (const hbp_pair*)y;
  if (p->a != q->a) return p->a < q->a ? -1 : 1;
  return p->b < q->b ? -1 : p->b > q->b;
}

static hbp_pair* want = NULL;
static size_t want_count = 0, want_capacity = 0;
static hbp_pair* before = NULL;
static size_t before_count = 0;

static void push_want(hbp_handle a, hbp_handle b) {
  if (want_count == want_capacity) {
    want_capacity = want_capacity ? 2 * want_capacity : 1024;
    want = (hbp_pair*)realloc(want, want_capacity * sizeof(hbp_pair));
    if (!want) abort();
  }
  want[want_count].a = a < b ? a : b;
  want[want_count].b = a < b ? b : a;
  ++want_count;
}

static void oracle(void) {
  static size_t order[MAX_LIVE];
  size_t s, t;
  want_count = 0;
  for (s = 0; s < live; ++s) order[s] = s;
  qsort(order, live, sizeof(size_t), by_min_x);
  for (s = 0; s < live; ++s) {
    const hbp_box* a = &boxes[order[s]];
    for (t = s + 1; t < live && boxes[order[t]].min[0] <= a->max[0]; ++t) {
      const hbp_box* b = &boxes[order[t]];
      if (statics[order[s]] && statics[order[t]]) continue;
      if (a->max[1] < b->min[1] || b->max[1] < a->min[1] || a->max[2] < b->min[2] || b->max[2] < a->min[2]) continue;
      push_want(handles[order[s]], handles[order[t]]);
    }
  }
  qsort(want, want_count, sizeof(hbp_pair), by_pair);
}

/* The pairs of `x` not in `y` (both sorted) equal got[0, n)? */
static int same_difference(const hbp_pair* x, size_t nx, const hbp_pair* y, size_t ny, const hbp_pair* got, size_t n) {
  size_t i = 0, j = 0, k = 0;
  while (i < nx) {
    if (j < ny && by_pair(&y[j], &x[i]) < 0) {
      ++j;
    } else if (j < ny && by_pair(&y[j], &x[i]) == 0) {
      ++i;
      ++j;
    } else {
      if (k >= n || by_pair(&got[k], &x[i]) != 0) return 0;
      ++k;
      ++i;
    }
  }
  return k == n;
}

static int check_frame(hbp_broad_phase* bp, const char* name, unsigned frame) {
  const hbp_pair* got;
  size_t n;
  CHECK(hbp_update(bp) == HBP_OK, "%s frame %u: %s", name, frame, hbp_last_error());
  CHECK(hbp_pairs(bp, &got, &n) == HBP_OK, "%s", hbp_last_error());
  CHECK(n == want_count && (n == 0 || memcmp(got, want, n * sizeof(hbp_pair)) == 0),
        "%s frame %u: %zu pairs, want %zu", name, frame, n, want_count);
  CHECK(hbp_created_pairs(bp, &got, &n) == HBP_OK, "%s", hbp_last_error());
  CHECK(same_difference(want, want_count, before, before_count, got, n), "%s frame %u: created pairs differ", name,
        frame);
  CHECK(hbp_removed_pairs(bp, &got, &n) == HBP_OK, "%s", hbp_last_error());
  CHECK(same_difference(before, before_count, want, want_count, got, n), "%s frame %u: removed pairs differ", name,
        frame);
  return 0;
}

#define SYSTEMS 3

int main(int argc, char** argv) {
  const unsigned seed = argc > 1 ? (unsigned)atoi(argv[1]) : 1u;
  const unsigned frames = argc > 2 ? (unsigned)atoi(argv[2]) : 200u;
  const char* names[SYSTEMS] = {"library threads", "POSIX threads", "reverse"};
  struct contract threads_log, reverse_log;
  hbp_broad_phase* bps[SYSTEMS];
  hbp_options o;
  const float side = 110.0f, size = 3.5f;
  size_t i;
  unsigned f;
  int s;
  memset(&threads_log, 0, sizeof threads_log);
  memset(&reverse_log, 0, sizeof reverse_log);
  threads_log.caller = reverse_log.caller = pthread_self();
  rng_state += seed * 0x9E3779B97F4A7C15ull;

  hbp_options_init(&o);
  CHECK(o.run_tasks == NULL && o.task_user == NULL, "hbp_options_init leaves run_tasks set");
  o.cell_limit = 64;
  o.threads = 2;
  CHECK(hbp_create(&o, &bps[0]) == HBP_OK, "%s", hbp_last_error());
  o.run_tasks = run_threads;
  o.task_user = &threads_log;
  o.threads = WORKERS + 1;
  CHECK(hbp_create(&o, &bps[1]) == HBP_OK, "%s", hbp_last_error());
  o.run_tasks = run_reverse;
  o.task_user = &reverse_log;
  o.threads = 4;
  CHECK(hbp_create(&o, &bps[2]) == HBP_OK, "%s", hbp_last_error());
  o.threads = 5000;
  {
    hbp_broad_phase* bad = NULL;
    CHECK(hbp_create(&o, &bad) == HBP_ERROR_INVALID_ARGUMENT && bad == NULL, "threads 5000 accepted with run_tasks");
  }

  /* 24000 moving and 1000 static objects: the parallel paths run. */
  for (i = 0; i < 25000; ++i) {
    boxes[i] = random_box(side, size);
    statics[i] = i >= 24000;
  }
  for (s = 0; s < SYSTEMS; ++s) {
    CHECK(hbp_add(bps[s], boxes, 24000, 0, 0, handles) == HBP_OK, "%s", hbp_last_error());
    CHECK(hbp_add(bps[s], boxes + 24000, 1000, 1, 0, handles + 24000) == HBP_OK, "%s", hbp_last_error());
  }
  live = 25000;

  for (f = 0; f < frames; ++f) {
    /* Moves: every moving object on even frames, a tenth on odd ones. */
    static hbp_handle moved[MAX_LIVE];
    static hbp_box to[MAX_LIVE];
    static size_t where[MAX_LIVE];
    size_t m = 0;
    for (i = 0; i < live; ++i) {
      int k;
      if (statics[i] || (f % 2 && rnd() % 10)) continue;
      to[m] = boxes[i];
      for (k = 0; k < 3; ++k) {
        const float d = uniform(-0.3f, 0.3f);
        to[m].min[k] += d;
        to[m].max[k] += d;
      }
      moved[m] = handles[i];
      where[m++] = i;
    }
    for (s = 0; s < SYSTEMS; ++s) CHECK(hbp_move(bps[s], moved, to, m) == HBP_OK, "%s", hbp_last_error());
    for (i = 0; i < m; ++i) boxes[where[i]] = to[i];
    /* Churn: a few objects removed (swapped out), as many added. */
    if (f % 3 == 0) {
      size_t gone = 0, k;
      static hbp_handle removed[64];
      hbp_box fresh[64];
      hbp_handle got[64];
      for (k = 0; k < 40; ++k) {
        const size_t at = rnd() % live;
        if (statics[at]) continue;
        removed[gone++] = handles[at];
        handles[at] = handles[live - 1];
        boxes[at] = boxes[live - 1];
        statics[at] = statics[live - 1];
        --live;
      }
      for (s = 0; s < SYSTEMS; ++s) CHECK(hbp_remove(bps[s], removed, gone) == HBP_OK, "%s", hbp_last_error());
      for (k = 0; k < gone; ++k) fresh[k] = random_box(side, size);
      for (s = 0; s < SYSTEMS; ++s) {
        CHECK(hbp_add(bps[s], fresh, gone, 0, 0, got) == HBP_OK, "%s", hbp_last_error());
        for (k = 0; k < gone; ++k) CHECK(s == 0 || handles[live + k] == got[k], "%s: handles differ", names[s]);
        if (s == 0)
          for (k = 0; k < gone; ++k) handles[live + k] = got[k];
      }
      for (k = 0; k < gone; ++k) {
        boxes[live + k] = fresh[k];
        statics[live + k] = 0;
      }
      live += gone;
    }
    oracle();
    for (s = 0; s < SYSTEMS; ++s)
      if (check_frame(bps[s], names[s], f)) return 1;
    free(before);
    before = (hbp_pair*)malloc((want_count ? want_count : 1) * sizeof(hbp_pair));
    if (!before) abort();
    if (want_count) memcpy(before, want, want_count * sizeof(hbp_pair));
    before_count = want_count;
  }
  CHECK(threads_log.batches > 0 && reverse_log.batches > 0, "a run_tasks was never called");
  CHECK(threads_log.nested == 0 && reverse_log.nested == 0, "run_tasks called nested");
  CHECK(threads_log.foreign == 0 && reverse_log.foreign == 0, "run_tasks called off the calling thread");
  for (s = 0; s < SYSTEMS; ++s) hbp_destroy(bps[s]);
  free(want);
  free(before);
  printf("ok: %u frames, %zu objects, %zu pairs at the end, %ld + %ld batches\n", frames, live, want_count,
         threads_log.batches, reverse_log.batches);
  return check_failures != 0;
}
