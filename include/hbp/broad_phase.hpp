// SPDX-License-Identifier: MIT
#pragma once
// The broad phase an engine lives on: persistent handles, static and moving
// objects, pair events, layer filtering and queries on the same structure.
//
//   hbp::BroadPhase bp({.engine = "sw", .threads = 2});
//   std::vector<hbp::Handle> h = bp.add(boxes);                  // moving, layer 0
//   bp.add(walls, {.is_static = true, .layer = 1});
//   hbp::Handle player = bp.add(hbp::Aabb{{0, 0, 0}, {1, 2, 1}});  // one object
//   bp.move(h, new_boxes);                                       // any time between updates
//   const hbp::BroadPhaseUpdate& u = bp.update();
//   for (hbp::Pair p : u.created) begin_contact(p.a, p.b);      // handles, a < b
//   for (hbp::Pair p : u.removed) end_contact(p.a, p.b);
//
// Semantics:
// - Boxes are closed float32 intervals (touching faces overlap), exactly as
//   HybridBroadPhase and the oracle.
// - A pair (a, b) is reported when the boxes overlap, at least one of the two
//   is moving (static-static pairs are never reported), the layers collide
//   (set_collides), the objects' filters accept each other (set_filter,
//   Box2D's rule) and the pair filter, when set, accepts it. Filtering
//   happens before a pair is stored. An object's box is the box it was
//   given grown by its margin (set_margin), or a swept union (move_swept).
// - Edits (add, move, move_swept, remove, set_layer, set_static, set_filter,
//   set_margin, set_collides, set_pair_filter) take effect at the next
//   update(). Each edit call validates its whole batch first and throws
//   InvalidInput naming the offending row or handle; a call that throws
//   changes nothing.
// - update() returns the frame's pairs and the pairs created and removed since
//   the previous update (a pair whose object was removed counts as removed;
//   a pair whose object moved away, changed layer filter or was rejected by a
//   new filter too). All three lists are sorted by (a, b), the same for any
//   thread count.
// - An update() that throws (CapacityExceeded, or whatever the pair filter
//   throws) applies nothing: last_update() and stats() stay those of the
//   last completed update, and the next update() that completes reports
//   every change since then.
// - Queries never change what the next update() reports.
// - Static objects cost nothing per frame while they do not change: they are
//   neither re-routed nor re-tested against each other.
// - Queries see the objects as of the last edit (not only the last update)
//   and are exact: query_box returns every object whose box overlaps the
//   closed query box, sorted by handle; query_ray every object whose box the
//   segment origin + t * direction, 0 <= t <= max_t, touches, sorted by entry
//   t (0 when the origin is inside), ties by handle.
// - Sleeping and waking: set_static(handles, true) makes moving objects
//   static (a body going to sleep), set_static(handles, false) makes static
//   objects moving (a body waking, a door that starts to move); handles,
//   boxes and layers stay. Events follow the pair rule above, by handle: a
//   pair reported before and after the change (one of its objects still
//   moving) is in neither created nor removed; a pair whose two objects are
//   both static after the change is removed (static-static pairs are never
//   reported), and created again when one of them wakes while the boxes
//   still overlap. A sleeping object costs what a static object costs.
// - Snapshots: snapshot() holds the whole logical state: the slot table
//   (handles, generations, free-slot order, so add() after restore() returns
//   the same handles), kinds, layers, boxes (and double boxes), the
//   objects' filters, user data, margins and sweeps, the layer table, the
//   last update's lists and stats, and the edits since it (the next
//   update() reports what the original's would). restore() replaces this
//   object's state with a snapshot's; the next update() and every call
//   after it behave as the original's. Not held: the options (this object
//   keeps its own; a double_precision snapshot restores only into a
//   double_precision broad phase, a float one only into a float one) and the
//   pair filter (restore() keeps the current one; the stored pairs were
//   filtered by the original's). The format is versioned, with
//   tagged sections and a checksum (docs/broad-phase.md, "Snapshots").
#include <array>
#include <cstddef>
#include <cstdint>
#include <concepts>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/aabb_d.hpp"
#include "hbp/collision_filter.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/limits.hpp"
#include "hbp/pair.hpp"

namespace hbp {

// A persistent object handle: slot index in the low 24 bits, generation in
// the high 8. A removed handle's slot is reused later with a new generation,
// so a stale handle is detected (InvalidInput) instead of silently touching
// the slot's new object. At most kMaxObjects live objects and kLayerCount
// layers (hbp/limits.hpp).
using Handle = std::uint32_t;
inline constexpr Handle kInvalidHandle = 0xFFFFFFFFu;

struct AddOptions {
  bool is_static = false;   // static objects are never tested against each other
  std::uint8_t layer = 0;   // 0 .. kLayerCount - 1
  Filter filter{};          // category / mask / group (hbp/collision_filter.hpp)
  std::uint64_t user_data = 0;  // the caller's value for each object added
  float margin = 0;             // >= 0, finite: grown onto every box the object is given
};

struct BroadPhaseUpdate {
  std::vector<Pair> pairs;    // every reported pair now (handles, a < b, sorted)
  std::vector<Pair> created;  // in pairs now, not at the previous update
  std::vector<Pair> removed;  // at the previous update, not now
};

struct BroadPhaseUpdateStats {
  std::uint32_t moving = 0, statics = 0;  // live objects
  // Objects counted once each per counter, whatever the number of edits: a
  // move to the box an object already has changes nothing. A kind change
  // (set_static) counts as a static object added (sleeping) or removed and a
  // moving object added (waking).
  std::uint32_t moved = 0;                // moving objects added, woken, or moved to another box, since the last update
  std::uint32_t static_changes = 0;       // static objects added, moved to another box or removed, objects put to
                                          // sleep or woken, since then
  double wall_ms = 0;                     // measured wall time of update()
};

// The nearest object a ray touches (BroadPhase::raycast_closest): its
// handle and entry t (0 when the origin is inside its box).
struct RayHit {
  Handle handle;
  float t;
};

class BroadPhase {
 public:
  // Pair predicate, called for pairs that pass the box, layer and object
  // filter tests, from any worker thread (must be thread-safe); true keeps
  // the pair. An exception it throws leaves update() unapplied and
  // propagates.
  using PairFilter = std::function<bool(Handle a, Handle b)>;

  // options.engine / cell_limit / threads / task_system / max_pairs as for HybridBroadPhase
  // (max_pairs bounds the reported pairs of a frame, and the moving/moving
  // pairs before the layer filter, so memory stays bounded: update() throws
  // CapacityExceeded and keeps the previous result); `sorted` is ignored
  // (results are always sorted).
  explicit BroadPhase(const BroadPhaseOptions& options = {});
  ~BroadPhase();
  BroadPhase(BroadPhase&&) noexcept;
  BroadPhase& operator=(BroadPhase&&) noexcept;

  // Provisions memory for up to `objects` moving objects before they are
  // added (the handles, the boxes, the hybrid system's partition: see
  // HybridBroadPhase::reserve); InvalidInput past kMaxObjects. Optional: a
  // first update() without it provisions the same memory itself.
  void reserve(std::size_t objects);
  // Adds boxes.size() objects; handles in the same order.
  std::vector<Handle> add(std::span<const Aabb> boxes, const AddOptions& options = {});
  // Adds one object (the batch add of one box); its handle.
  Handle add(const Aabb& box, const AddOptions& options = {});
  // Replaces the boxes of `handles` (same length); static objects may move too.
  void move(std::span<const Handle> handles, std::span<const Aabb> boxes);
  void remove(std::span<const Handle> handles);
  // Changes the layer of `handles`.
  void set_layer(std::span<const Handle> handles, std::uint8_t layer);

  // Makes `handles` static (is_static: sleeping) or moving (waking), keeping
  // their handles, boxes and layers (see Semantics). Objects already of that
  // kind are left as they are. InvalidInput naming the row of an unknown,
  // stale or repeated handle; a call that throws changes nothing.
  void set_static(std::span<const Handle> handles, bool is_static);

  // The whole logical state as bytes (see Semantics). The snapshot calls
  // may run concurrently with queries and each other, not with edits.
  std::vector<std::byte> snapshot() const;
  // snapshot() into a caller's buffer: its length in bytes, written to
  // out[0, length); CapacityExceeded (nothing written) when out is shorter
  // than snapshot_size().
  std::size_t snapshot_size() const;
  std::size_t snapshot(std::span<std::byte> out) const;
  // Replaces the state with a snapshot's (the options and pair filter stay;
  // references update() and last_update() returned are invalidated).
  // InvalidInput naming what is wrong with malformed, truncated, corrupted
  // or wrong-version data, and the object is unchanged.
  void restore(std::span<const std::byte> data);
  // A new broad phase with `options` and a snapshot's state; its
  // double_precision is the snapshot's, whatever `options` says.
  static BroadPhase from_snapshot(std::span<const std::byte> data, const BroadPhaseOptions& options = {});

  // Symmetric; every pair of layers collides by default.
  void set_collides(std::uint32_t layer_a, std::uint32_t layer_b, bool collides);
  bool collides(std::uint32_t layer_a, std::uint32_t layer_b) const;
  // An empty function removes the filter.
  void set_pair_filter(PairFilter filter);

  const BroadPhaseUpdate& update();
  const BroadPhaseUpdate& last_update() const;
  const BroadPhaseUpdateStats& stats() const;

  // Safe to call concurrently with each other, not with edits. InvalidInput
  // for a malformed box, a non-finite origin or direction, or max_t < 0 or
  // NaN (infinity is allowed).
  //
  // Each query comes in three forms with the same hits in the same order:
  // - returning a new vector;
  // - writing into `out` (cleared first, its capacity reused: a caller that
  //   keeps one vector allocates nothing once it is large enough), returning
  //   out.size();
  // - calling `visit(handle)` per hit until it returns false (early out; for
  //   a ray, hits come nearest first, so stopping after one gives the nearest
  //   object), returning the number of calls. `visit` may run queries itself.
  // Ray origins and directions are std::array<float, 3> (Vec3f), so braced
  // lists work: query_ray({0, 0, 0}, {1, 0, 0}, 10); the vector-returning
  // form also takes raw float[3] arrays.
  using HitVisitor = std::function<bool(Handle)>;
  using Vec3f = std::array<float, 3>;
  std::vector<Handle> query_box(const Aabb& box) const;
  std::size_t query_box(const Aabb& box, std::vector<Handle>& out) const;
  std::size_t query_box(const Aabb& box, const HitVisitor& visit) const;
  std::vector<Handle> query_ray(const float origin[3], const float direction[3], float max_t) const;
  std::vector<Handle> query_ray(const Vec3f& origin, const Vec3f& direction, float max_t) const;
  std::size_t query_ray(const Vec3f& origin, const Vec3f& direction, float max_t, std::vector<Handle>& out) const;
  std::size_t query_ray(const Vec3f& origin, const Vec3f& direction, float max_t, const HitVisitor& visit) const;

  // The first hit of query_ray(origin, direction, max_t) (smallest entry t,
  // ties by smallest handle), or nothing; same validation. It walks both
  // trees nearest-first and skips every subtree whose entry t is beyond the
  // best hit so far, so it reads a few blocks where query_ray reads all the
  // hits and sorts them.
  std::optional<RayHit> raycast_closest(const Vec3f& origin, const Vec3f& direction, float max_t) const;
  // Box cast: every object whose box the moving box box + t * displacement,
  // 0 <= t <= 1, touches (closed boxes), sorted by the first such t, ties
  // by handle. Exact under the slab test of the target grown by the box
  // (Minkowski sum: [min - box.max, max - box.min] per axis, one float
  // subtraction each) against the segment from 0 along displacement: on an
  // axis the displacement leaves at 0 it is exactly the closed overlap, and
  // with displacement 0 the hits are query_box(box)'s. InvalidInput for a
  // malformed box or a non-finite displacement.
  std::vector<Handle> query_box_cast(const Aabb& box, const Vec3f& displacement) const;
  std::size_t query_box_cast(const Aabb& box, const Vec3f& displacement, std::vector<Handle>& out) const;
  std::size_t query_box_cast(const Aabb& box, const Vec3f& displacement, const HitVisitor& visit) const;

  // ---- Fast movers ----
  //
  // An object's margin (AddOptions::margin, set_margin) is grown onto every
  // box it is given, on every side: the stored box (box(h), pairs, queries)
  // is the given box grown by the margin, so pairs are reported for the
  // grown boxes (a speculative contact distance). set_margin applies to the
  // boxes given from then on (add, move, move_swept), not to the box the
  // object has now. InvalidInput for a negative or non-finite margin, or a
  // grown box that is not finite. A double_precision broad phase has no
  // margins and no swept moves (InvalidInput): its pairs are those of the
  // AabbD boxes as given, so grow those.
  void set_margin(std::span<const Handle> handles, float margin);
  float margin(Handle h) const;
  // Swept boxes: each object's box becomes the union of its previous box and
  // the new one (both grown by its margin): the candidates a continuous
  // collision test needs. The previous box is the one given to the object's
  // last move_swept (so consecutive sweeps do not accumulate), or its box
  // when the last move was a plain one. Same validation as move().
  void move_swept(std::span<const Handle> handles, std::span<const Aabb> boxes);

  // ---- Object filters, user data, filtered queries ----
  //
  // A pair is stored only when the layer table, the objects' Filters
  // (should_collide: Box2D's b2Filter rule) and the pair filter all accept
  // it (the pair filter is called only for pairs the other two accept).
  // While every live object has the default Filter the filter test costs
  // nothing (the unfiltered paths of a frame stay in use). The pair filter
  // does not apply to queries: they take a QueryFilter.
  void set_filter(std::span<const Handle> handles, const Filter& filter);
  Filter filter(Handle h) const;
  // One value per handle (same lengths); takes effect at once.
  void set_user_data(std::span<const Handle> handles, std::span<const std::uint64_t> values);
  std::uint64_t user_data(Handle h) const;  // O(1); InvalidInput for an unknown or stale handle
  // The user data of each pair's two objects (out.size() == pairs.size()),
  // or of each handle (a query's hits), by slot lookups: no side table
  // needed. A handle no longer live (a `removed` pair's object removed
  // since) gives 0.
  void pair_user_data(std::span<const Pair> pairs, std::span<std::array<std::uint64_t, 2>> out) const;
  void user_data(std::span<const Handle> handles, std::span<std::uint64_t> out) const;
  // Every query with a QueryFilter last: only objects whose layer bit is in
  // filter.layers_mask and whose category shares a bit with
  // filter.category_mask are reported (raycast_closest: the nearest such).
  std::vector<Handle> query_box(const Aabb& box, const QueryFilter& filter) const;
  std::size_t query_box(const Aabb& box, std::vector<Handle>& out, const QueryFilter& filter) const;
  std::size_t query_box(const Aabb& box, const HitVisitor& visit, const QueryFilter& filter) const;
  std::vector<Handle> query_ray(const Vec3f& origin, const Vec3f& direction, float max_t,
                                const QueryFilter& filter) const;
  std::size_t query_ray(const Vec3f& origin, const Vec3f& direction, float max_t, std::vector<Handle>& out,
                        const QueryFilter& filter) const;
  std::size_t query_ray(const Vec3f& origin, const Vec3f& direction, float max_t, const HitVisitor& visit,
                        const QueryFilter& filter) const;
  std::optional<RayHit> raycast_closest(const Vec3f& origin, const Vec3f& direction, float max_t,
                                        const QueryFilter& filter) const;
  std::vector<Handle> query_box_cast(const Aabb& box, const Vec3f& displacement, const QueryFilter& filter) const;
  std::size_t query_box_cast(const Aabb& box, const Vec3f& displacement, std::vector<Handle>& out,
                             const QueryFilter& filter) const;
  std::size_t query_box_cast(const Aabb& box, const Vec3f& displacement, const HitVisitor& visit,
                             const QueryFilter& filter) const;

  std::size_t size() const;  // live objects
  bool contains(Handle h) const;
  // InvalidInput for an unknown or stale handle.
  Aabb box(Handle h) const;
  bool is_static(Handle h) const;
  std::uint8_t layer(Handle h) const;

  const BroadPhaseOptions& options() const;

  // ---- large worlds ------------------------------------------------------
  //
  // Origin shift (PhysX shiftOrigin): re-bases every object, static and
  // moving, by subtracting `offset` in one pass; boxes given afterwards (add,
  // move, queries) are in the new frame. Each coordinate x becomes
  // fl(x - offset[k]) in the box's own precision (float32 subtraction here,
  // float64 in double-precision mode, with the offset taken exactly as a
  // double); min and max go through the same monotone operation, so a box
  // never inverts. The pairs after the shift are those of the shifted boxes;
  // the next update() reports events only for the pairs whose overlap the
  // rounding of the shift changed (none when every x - offset is exact, e.g.
  // offsets that are multiples of the float spacing of the coordinates).
  // Every cache (static tree, candidate lists, quiet and fat boxes, the
  // moving tree of the queries) follows; shifted objects count as moved in
  // stats(). InvalidInput, nothing applied, for a non-finite offset or a
  // shift that would take a coordinate outside the finite range.
  void shift_origin(const std::array<float, 3>& offset);
  // The same with a double offset: exact in double-precision mode; a float
  // BroadPhase rounds each offset[k] to the nearest float first.
  void shift_origin_d(const std::array<double, 3>& offset);

  // Double precision (options.double_precision): boxes are AabbD, kept as
  // given. The float engine runs on each box rounded outward to float32
  // (min down, max up), so every true pair is among its candidates; each
  // candidate is then confirmed on the double boxes before it is stored,
  // so the pairs, created and removed are exactly those of the double boxes
  // (candidates whose two float boxes equal their double boxes skip the
  // confirmation: their float test was exact). The pair filter is asked
  // only about confirmed pairs; max_pairs bounds the float candidates too.
  // The float filter is finest near the origin (float spacing grows with
  // |x|: 1 at 1e7, 64 at 1e9): far from it more candidates reach the double
  // test, so keep the action near the origin with shift_origin.
  // Float boxes on a double BroadPhase (add, move, box) and double boxes on
  // a float one throw InvalidInput.
  std::vector<Handle> add(std::span<const AabbD> boxes, const AddOptions& options = {});
  // One object. (A template so that a braced list, add({{..}, {..}}), stays
  // an Aabb.)
  template <std::same_as<AabbD> Box>
  Handle add(const Box& box, const AddOptions& options = {}) {
    return add(std::span<const AabbD>(&box, 1), options)[0];
  }
  void move(std::span<const Handle> handles, std::span<const AabbD> boxes);
  // The object's double box as given (after any shift_origin).
  AabbD box_d(Handle h) const;
  // Double-precision mode only: every object whose double box overlaps the
  // closed double box, sorted by handle (the float tree finds candidates,
  // each is confirmed in double). The float query_box forms take the Aabb
  // as the double box it denotes (exact). query_ray tests the outward float
  // boxes: every object the segment touches, and possibly objects within
  // one float rounding of it.
  template <std::same_as<AabbD> Box>
  std::vector<Handle> query_box(const Box& box) const {
    std::vector<Handle> out;
    query_box_d(box, out);
    return out;
  }
  template <std::same_as<AabbD> Box>
  std::size_t query_box(const Box& box, std::vector<Handle>& out) const {
    query_box_d(box, out);
    return out.size();
  }
  template <std::same_as<AabbD> Box>
  std::size_t query_box(const Box& box, const HitVisitor& visit) const {
    std::vector<Handle> hits;
    query_box_d(box, hits);
    std::size_t calls = 0;
    for (const Handle h : hits) {
      ++calls;
      if (!visit(h)) break;
    }
    return calls;
  }
  template <std::same_as<AabbD> Box>
  std::vector<Handle> query_box(const Box& box, const QueryFilter& filter) const {
    std::vector<Handle> out;
    query_box_d(box, out, &filter);
    return out;
  }
  template <std::same_as<AabbD> Box>
  std::size_t query_box(const Box& box, std::vector<Handle>& out, const QueryFilter& filter) const {
    query_box_d(box, out, &filter);
    return out.size();
  }

 private:
  void query_box_d(const AabbD& box, std::vector<Handle>& out, const QueryFilter* filter = nullptr) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp
