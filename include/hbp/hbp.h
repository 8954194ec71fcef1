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

typedef struct hbp_options {
  const char* engine;   /* cell engine: NULL or "sw" (default), "sw-allpairs", "brute" */
  uint32_t threads;     /* worker threads; 0: all cores; at most 1024 */
  uint32_t cell_limit;  /* objects per k-d cell; 0: the engine's default, else >= 2 */
  uint64_t max_pairs;   /* most pairs one update may report; 0: unlimited */
} hbp_options;

/* "0.1.0": the library's version. */
const char* hbp_version(void);

/* A short English name of a status ("ok", "invalid argument", ...). */
const char* hbp_status_string(hbp_status status);

/* The message of the last call on this thread that failed, or "" after a
 * call that succeeded (each call resets it). Valid until the next call on
 * this thread. */
const char* hbp_last_error(void);

/* Fills *options with the defaults (engine "sw", all cores, no limits). */
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

/* Live objects (writes *count). */
hbp_status hbp_size(const hbp_broad_phase* bp, size_t* count);

/* The box an object has now (HBP_ERROR_INVALID_ARGUMENT for a stale handle). */
hbp_status hbp_get_box(const hbp_broad_phase* bp, hbp_handle handle, hbp_box* box_out);

/* 1 when the handle names a live object, else 0 (also for bp == NULL). */
int hbp_contains(const hbp_broad_phase* bp, hbp_handle handle);

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
