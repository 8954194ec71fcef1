/* SPDX-License-Identifier: MIT */
/*
 * hbp.h: the C API of hybrid-broadphase (C99; usable from C++ and from any
 * language with a C foreign-function interface). It wraps hbp::BroadPhase
 * (hbp/broad_phase.hpp): persistent handles, batched add / move / remove,
 * an update that reports the pairs created and removed since the previous
 * one, and box and ray queries. docs/c-api.md has a complete example.
 *
 *   hbp_broad_phase* bp;
 *   hbp_options o;
 *   hbp_options_init(&o);
 *   o.threads = 2;
 *   if (hbp_create(&o, &bp) != HBP_OK) { fprintf(stderr, "%s\n", hbp_last_error()); ... }
 *   hbp_add(bp, boxes, n, 0, 0, handles);       // n moving objects on layer 0
 *   hbp_update(bp);
 *   hbp_created_pairs(bp, &pairs, &count);      // handles, a < b, sorted
 *   hbp_destroy(bp);
 *
 * Contract:
 * - Every function returning hbp_status returns HBP_OK on success; on failure
 *   it changes nothing (a batch is validated whole before any of it is
 *   applied) and hbp_last_error() says why, naming the offending row,
 *   handle or option. No C++ exception ever leaves this API.
 * - Boxes are closed float intervals (touching faces overlap); NaN,
 *   infinite or inverted (min > max) boxes are rejected.
 * - A pair (a, b), a < b, is reported when the boxes overlap, at least one
 *   of the two objects is moving (static-static pairs are never reported)
 *   and their layers collide (hbp_set_collides).
 * - Edits take effect at the next hbp_update(). Queries see the objects as
 *   of the last edit.
 * - One hbp_broad_phase may be used by one thread at a time (queries may run
 *   concurrently with each other, not with edits or updates). Different
 *   hbp_broad_phase objects are independent.
 */
#ifndef HBP_HBP_H
#define HBP_HBP_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* An opaque broad phase: created by hbp_create, freed by hbp_destroy. */
typedef struct hbp_broad_phase hbp_broad_phase;

/* A persistent object handle. A removed object's handle is never valid
 * again (its slot is reused with a new generation): using it is an error. */
typedef uint32_t hbp_handle;
#define HBP_INVALID_HANDLE 0xFFFFFFFFu

/* The most live objects and the number of layers. */
#define HBP_MAX_OBJECTS 16777215u
#define HBP_LAYER_COUNT 32u

typedef enum hbp_status {
  HBP_OK = 0,
  /* A NULL pointer, a malformed box (row named), an unknown or stale
   * handle, a layer >= HBP_LAYER_COUNT, an unknown engine, a bad option. */
  HBP_ERROR_INVALID_ARGUMENT = 1,
  /* More pairs than options.max_pairs, or more than HBP_MAX_OBJECTS live
   * objects, or a buffer smaller than needed (hbp_snapshot). Nothing was
   * applied; the previous update's results stay. */
  HBP_ERROR_CAPACITY = 2,
  /* Memory could not be allocated. Nothing was applied. */
  HBP_ERROR_OUT_OF_MEMORY = 3,
  /* A failure that is none of the above (a bug: please report it). */
  HBP_ERROR_INTERNAL = 4
} hbp_status;

/* An axis-aligned box: min[i] <= max[i] on each axis. */
typedef struct hbp_box {
  float min[3];
  float max[3];
} hbp_box;

/* A reported pair of handles, a < b. */
typedef struct hbp_pair {
  hbp_handle a;
  hbp_handle b;
} hbp_pair;

/* The engine's job system (docs/c-api.md, "Your engine's job system").
 * The library hands it batches of tasks: run_tasks(task_user, count, task,
 * context) must call task(context, i) exactly once for every i in
 * [0, count), on any threads (the calling one included, in any order), and
 * return only when every call has returned. It is called on the thread that
 * called into the library, never from inside one of its own tasks (no
 * nesting to support). task never fails and never unwinds: the library
 * keeps a task's error and reports it from the call that ran the batch. */
typedef void (*hbp_task_fn)(void* context, uint32_t task);
typedef void (*hbp_run_tasks_fn)(void* task_user, uint32_t task_count, hbp_task_fn task, void* context);

typedef struct hbp_options {
  const char* engine;   /* cell engine: NULL or "sw" (default), "sw-allpairs", "brute" */
  uint32_t threads;     /* worker threads; 0: all cores; at most 1024. With run_tasks: how many
                           tasks run_tasks can run at once (0: the machine's cores) */
  uint32_t cell_limit;  /* objects per k-d cell; 0: the engine's default, else >= 2 */
  uint64_t max_pairs;   /* most pairs one update may report; 0: unlimited */
  hbp_run_tasks_fn run_tasks;  /* the engine's job system; NULL: the library's own threads */
  void* task_user;             /* passed to run_tasks as is */
  /* Non-zero: boxes are hbp_box_d (hbp_add_d, hbp_move_d, hbp_get_box_d),
   * pairs exact on the doubles; hbp_add / hbp_move / hbp_get_box are then
   * errors. 0 (default): float boxes, and the _d functions are errors. */
  int double_precision;
} hbp_options;

/* "0.1.0": the library's version. */
const char* hbp_version(void);

/* A short English name of a status ("ok", "invalid argument", ...). */
const char* hbp_status_string(hbp_status status);

/* The message of the last call on this thread that failed, or "" after a
 * call that succeeded (each call resets it). Valid until the next call on
 * this thread. */
const char* hbp_last_error(void);

/* Fills *options with the defaults (engine "sw", all cores on the library's
 * own threads, no limits). */
void hbp_options_init(hbp_options* options);

/* Creates a broad phase; options may be NULL (the defaults). On failure
 * *out is set to NULL. */
hbp_status hbp_create(const hbp_options* options, hbp_broad_phase** out);

/* Frees a broad phase and everything it returned. NULL is a no-op. */
void hbp_destroy(hbp_broad_phase* bp);

/* Adds count objects with the given boxes, all static or all moving, on
 * `layer`; writes their handles to handles_out[0 .. count-1]. */
hbp_status hbp_add(hbp_broad_phase* bp, const hbp_box* boxes, size_t count, int is_static, uint8_t layer,
                   hbp_handle* handles_out);

/* Gives handles[i] the box boxes[i], for i < count. Static objects may move. */
hbp_status hbp_move(hbp_broad_phase* bp, const hbp_handle* handles, const hbp_box* boxes, size_t count);

/* Removes count objects. A handle given twice is an error. */
hbp_status hbp_remove(hbp_broad_phase* bp, const hbp_handle* handles, size_t count);

/* Whether layers a and b collide (symmetric; every pair collides at first). */
hbp_status hbp_set_collides(hbp_broad_phase* bp, uint32_t layer_a, uint32_t layer_b, int collides);

/* Finds the pairs of the objects as they are now. On HBP_ERROR_CAPACITY
 * nothing is applied and the next update that succeeds reports every change
 * since the last one that did. */
hbp_status hbp_update(hbp_broad_phase* bp);

/* The last successful update's pairs: every pair now, the pairs new since
 * the update before, and the pairs gone since then. Each list is sorted by
 * (a, b). The array stays valid and unchanged until the next hbp_update,
 * hbp_restore or hbp_destroy of bp; *pairs may be NULL when *count is 0. */
hbp_status hbp_pairs(const hbp_broad_phase* bp, const hbp_pair** pairs, size_t* count);
hbp_status hbp_created_pairs(const hbp_broad_phase* bp, const hbp_pair** pairs, size_t* count);
hbp_status hbp_removed_pairs(const hbp_broad_phase* bp, const hbp_pair** pairs, size_t* count);

/* Called once per hit with the caller's pointer. Return non-zero to go on,
 * 0 to stop the query there. It must not call hbp_* edit functions on the
 * same broad phase, and (when called from C++) must not throw. */
typedef int (*hbp_hit_callback)(void* user, hbp_handle handle);

/* Every object whose box overlaps the closed box `box`, in handle order.
 * *hits_out (may be NULL) receives the number of callback calls. */
hbp_status hbp_query_box(const hbp_broad_phase* bp, const hbp_box* box, hbp_hit_callback callback, void* user,
                         size_t* hits_out);

/* Every object whose box the segment origin + t * direction,
 * 0 <= t <= max_t, touches, in order of entry t (0 when the origin is
 * inside), ties by handle. max_t may be INFINITY, not negative or NaN. */
hbp_status hbp_query_ray(const hbp_broad_phase* bp, const float origin[3], const float direction[3], float max_t,
                         hbp_hit_callback callback, void* user, size_t* hits_out);

/* The first hit of hbp_query_ray (smallest entry t, ties by smallest
 * handle), found without visiting the others: *hit_out is 1 and
 * *handle_out, *t_out are its handle and entry t, or *hit_out is 0 (and
 * *handle_out is HBP_INVALID_HANDLE, *t_out 0) when the segment touches
 * nothing. Same arguments and errors as hbp_query_ray. */
hbp_status hbp_raycast_closest(const hbp_broad_phase* bp, const float origin[3], const float direction[3], float max_t,
                               hbp_handle* handle_out, float* t_out, int* hit_out);

/* Box cast: every object whose box the moving box box + t * displacement,
 * 0 <= t <= 1, touches, in order of the first such t, ties by handle (the
 * slab test of each target grown by the box, docs/broad-phase.md). With a
 * zero displacement the hits are hbp_query_box's. */
hbp_status hbp_box_cast(const hbp_broad_phase* bp, const hbp_box* box, const float displacement[3],
                        hbp_hit_callback callback, void* user, size_t* hits_out);

/* Fast movers. An object's margin (>= 0, finite; 0 at first) is grown onto
 * every box it is given from then on (hbp_add, hbp_move, hbp_move_swept):
 * its stored box, and so its pairs and query hits, are the given box grown
 * by the margin on every side (a speculative contact distance).
 * hbp_move_swept sets each object's box to the union of its previous box
 * and the new one (the candidates of a continuous collision test); the
 * previous box is the one given to its last hbp_move_swept, or its box
 * after a plain move. */
hbp_status hbp_set_margin(hbp_broad_phase* bp, const hbp_handle* handles, size_t count, float margin);
hbp_status hbp_move_swept(hbp_broad_phase* bp, const hbp_handle* handles, const hbp_box* boxes, size_t count);

/* An object's filter (Box2D's b2Filter rule): two objects pair when they
 * share a nonzero group, always if it is positive and never if negative;
 * otherwise when each one's category has a bit in the other's mask. Applied
 * with the layer table before a pair is stored. Defaults (hbp_filter_init):
 * category 1, every mask bit, group 0. */
typedef struct hbp_filter {
  uint64_t category;
  uint64_t mask;
  int32_t group;
} hbp_filter;
void hbp_filter_init(hbp_filter* filter);

/* Gives count objects the filter (taking effect at the next update). */
hbp_status hbp_set_filter(hbp_broad_phase* bp, const hbp_handle* handles, size_t count, const hbp_filter* filter);
hbp_status hbp_get_filter(const hbp_broad_phase* bp, hbp_handle handle, hbp_filter* filter_out);

/* A 64-bit value per object, 0 until set. hbp_pair_user_data writes the
 * values of each pair's a and b to out[2 i], out[2 i + 1] (0 for an object no
 * longer live: a removed pair's object removed since). */
hbp_status hbp_set_user_data(hbp_broad_phase* bp, const hbp_handle* handles, const uint64_t* values, size_t count);
hbp_status hbp_get_user_data(const hbp_broad_phase* bp, hbp_handle handle, uint64_t* value_out);
hbp_status hbp_pair_user_data(const hbp_broad_phase* bp, const hbp_pair* pairs, size_t count, uint64_t* out);

/* The objects a query reports: layer bit in layers_mask and category
 * meeting category_mask (hbp_query_filter_init: every layer, every bit). The
 * *_filtered queries are the queries above with a filter; NULL: none. */
typedef struct hbp_query_filter {
  uint32_t layers_mask;
  uint64_t category_mask;
} hbp_query_filter;
void hbp_query_filter_init(hbp_query_filter* filter);
hbp_status hbp_query_box_filtered(const hbp_broad_phase* bp, const hbp_box* box, const hbp_query_filter* filter,
                                  hbp_hit_callback callback, void* user, size_t* hits_out);
hbp_status hbp_query_ray_filtered(const hbp_broad_phase* bp, const float origin[3], const float direction[3],
                                  float max_t, const hbp_query_filter* filter, hbp_hit_callback callback, void* user,
                                  size_t* hits_out);
hbp_status hbp_raycast_closest_filtered(const hbp_broad_phase* bp, const float origin[3], const float direction[3],
                                        float max_t, const hbp_query_filter* filter, hbp_handle* handle_out,
                                        float* t_out, int* hit_out);
hbp_status hbp_box_cast_filtered(const hbp_broad_phase* bp, const hbp_box* box, const float displacement[3],
                                 const hbp_query_filter* filter, hbp_hit_callback callback, void* user,
                                 size_t* hits_out);

/* Live objects (writes *count). */
hbp_status hbp_size(const hbp_broad_phase* bp, size_t* count);

/* The box an object has now (HBP_ERROR_INVALID_ARGUMENT for a stale handle). */
hbp_status hbp_get_box(const hbp_broad_phase* bp, hbp_handle handle, hbp_box* box_out);

/* 1 when the handle names a live object, else 0 (also for bp == NULL). */
int hbp_contains(const hbp_broad_phase* bp, hbp_handle handle);

/* ---- Large worlds ------------------------------------------------------
 *
 * Re-bases every object (static and moving) by subtracting offset: each
 * coordinate x becomes x - offset[i] rounded in the box's precision (float
 * for a float broad phase, which first rounds each offset[i] to the nearest
 * float; double in double-precision mode). Boxes given afterwards are in the
 * new frame. The next hbp_update reports events only for pairs whose overlap
 * the rounding changed (none for exact shifts). A non-finite offset, or a
 * shift that takes a coordinate out of the finite range, is an error and
 * changes nothing. */
hbp_status hbp_shift_origin(hbp_broad_phase* bp, const double offset[3]);

/* A box in double precision (options.double_precision): min[i] <= max[i].
 * The broad phase filters with each box rounded outward to float and
 * confirms every candidate pair on the doubles, so pairs and events are
 * exactly those of the double boxes; the float filter is finest near the
 * origin (keep the action there with hbp_shift_origin). */
typedef struct hbp_box_d {
  double min[3];
  double max[3];
} hbp_box_d;

/* hbp_add, hbp_move, hbp_get_box and hbp_query_box for hbp_box_d boxes
 * (double-precision broad phases only). hbp_query_box and hbp_query_ray
 * also work in double-precision mode: the float box is the double box it
 * denotes (exact); a ray is tested against the outward float boxes, so it
 * may also report objects within one float rounding of the segment. */
hbp_status hbp_add_d(hbp_broad_phase* bp, const hbp_box_d* boxes, size_t count, int is_static, uint8_t layer,
                     hbp_handle* handles_out);
hbp_status hbp_move_d(hbp_broad_phase* bp, const hbp_handle* handles, const hbp_box_d* boxes, size_t count);
hbp_status hbp_get_box_d(const hbp_broad_phase* bp, hbp_handle handle, hbp_box_d* box_out);
hbp_status hbp_query_box_d(const hbp_broad_phase* bp, const hbp_box_d* box, hbp_hit_callback callback, void* user,
                           size_t* hits_out);

/* ---- Sleeping and waking ---- */

/* Makes count objects static (is_static != 0: bodies going to sleep) or
 * moving (0: waking), keeping their handles, boxes and layers; objects
 * already of that kind stay as they are. An unknown, stale or repeated
 * handle is an error naming its row. At the next hbp_update a pair that is
 * reported before and after (one of its objects still moving) is neither
 * created nor removed; a pair whose two objects are now static is removed
 * (static-static pairs are never reported), and created again when one of
 * them wakes while the boxes still overlap. A sleeping object costs what a
 * static one costs. */
hbp_status hbp_set_static(hbp_broad_phase* bp, const hbp_handle* handles, size_t count, int is_static);

/* ---- Snapshots ---- */

/* A snapshot is bp's whole logical state as bytes: the objects with their
 * handles, kinds, layers and boxes, the order free slots are reused in (so
 * handles added after a restore are the same), the layer table, the last
 * update's pairs and what was edited since. A broad phase it is restored
 * into reports from its next hbp_update on what bp would. Not held: the
 * options (the restored object keeps its own). The bytes are a versioned,
 * checksummed, little-endian format (docs/broad-phase.md, "Snapshots"),
 * with no pointers: they may be stored and restored by another process.
 *
 * hbp_snapshot_size writes the snapshot's length in bytes to *size_out.
 * hbp_snapshot writes the snapshot into buffer[0 .. *size_out) and its
 * length to *size_out; when capacity is smaller than that length it writes
 * nothing into buffer, sets *size_out to the length needed and returns
 * HBP_ERROR_CAPACITY (buffer may be NULL when capacity is 0). */
hbp_status hbp_snapshot_size(const hbp_broad_phase* bp, size_t* size_out);
hbp_status hbp_snapshot(const hbp_broad_phase* bp, void* buffer, size_t capacity, size_t* size_out);

/* Replaces bp's state with the snapshot in data[0 .. size). Malformed,
 * truncated, corrupted or wrong-version data is HBP_ERROR_INVALID_ARGUMENT
 * naming what is wrong, with bp unchanged. */
hbp_status hbp_restore(hbp_broad_phase* bp, const void* data, size_t size);

#ifdef __cplusplus
}
#endif

#endif /* HBP_HBP_H */
