// SPDX-License-Identifier: MIT
// hbp::BroadPhase: handles over the hybrid system (moving objects), a flat
// BVH (static objects) and fat-box candidate caches (moving vs static).
//
// Layout. Every object has a slot (handle_table.hpp). Moving objects live in
// dense SoA arrays (moving_boxes, moving_handle) ordered by handle, so the
// hybrid system's sorted id pairs map to sorted handle pairs; an indexed
// moving object's box is only there (slot_box holds it until the object
// gets its index, and again when the moving membership changes). Static
// objects have their box in slot_box, dense copies in
// static_boxes/static_handle and a BoxTree built when the statics change.
// The moving objects' caches of static candidates are dense too (memory
// follows the moving objects).
//
// A frame: the hybrid system finds the moving/moving pairs (or, while the
// moving objects are few and sparse, fat-box candidate pairs kept across
// frames: fat_moving_pairs.hpp); each moving object re-tests the static
// candidates cached for its fat box (its box grown by half its largest side)
// and re-queries the static tree only when its box left the fat box or the
// statics changed; an object still inside its quiet box (no candidate's
// overlap can change) skips its list, and when only
// moving boxes changed the pairs whose overlap flipped are merged into last
// frame's moving/static list instead of re-sorting it. Layer table and pair
// filter apply before a pair is kept; the sorted lists are merged, and
// created/removed come from a merge with the previous frame's pairs.
//
// The all-moving frame (no statics, no layer table or filter in force) is
// the whole-frame path plus events: move() of every moving object in handle
// order checks and writes the boxes in one pass, the hybrid system runs
// without re-checking them, and its pair list becomes the result without a
// copy (or is mapped to handles inside the event merge).
#include "hbp/broad_phase.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <atomic>
#include <chrono>
#include <mutex>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "hbp/error.hpp"
#include "geometry/box_screen.hpp"
#include "pipeline/arena_threads.hpp"
#include "pipeline/box_tree.hpp"
#include "pipeline/broad_phase_snapshot.hpp"
#include "pipeline/fat_moving_pairs.hpp"
#include "pipeline/handle_table.hpp"
#include "pipeline/pair_events.hpp"
#include "pipeline/screened_boxes.hpp"
#include "pipeline/parallel_pair_sort.hpp"
#include "support/clock.hpp"
#include "support/retained.hpp"

namespace hbp {

using detail::BoxTree;
using detail::FatMovingPairs;
using detail::fat_box;
using detail::inside;
using detail::HandleTable;

namespace {

constexpr std::uint32_t kNoIndex = HandleTable::kNoIndex;
constexpr std::size_t kChunk = 1024;  // items per parallel task (fixed: deterministic output)
// The retained rule's slack of a moving object's candidate list (there are
// millions of lists: the default slack would be kept by each).
constexpr std::size_t kCandidateSlack = 64;

// The float just above x (x not NaN; +inf stays), without a libm call.
inline float next_up(float x) {
  if (x == std::numeric_limits<float>::infinity()) return x;
  if (x == 0.0f) return std::numeric_limits<float>::denorm_min();
  const auto bits = std::bit_cast<std::uint32_t>(x);
  return std::bit_cast<float>(x > 0.0f ? bits + 1 : bits - 1);
}
// The float just below x (x not NaN; -inf stays).
inline float next_down(float x) { return -next_up(-x); }

// Same box by value (-0 equals +0): a move to it changes no overlap.
inline bool same_box(const Aabb& a, const Aabb& b) {
  return a.min[0] == b.min[0] && a.min[1] == b.min[1] && a.min[2] == b.min[2] && a.max[0] == b.max[0] &&
         a.max[1] == b.max[1] && a.max[2] == b.max[2];
}

// Runs body(begin, end, out) over fixed chunks of [0, n) in parallel and
// concatenates the chunks' outputs in chunk order.
template <class Body>
void parallel_collect(std::size_t n, std::vector<Pair>& out, Body&& body) {
  out.clear();
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  if (chunks <= 1) {
    body(std::size_t(0), n, out);
    return;
  }
  std::vector<std::vector<Pair>> parts(chunks);
  tbb::parallel_for(std::size_t(0), chunks,
                    [&](std::size_t c) { body(c * kChunk, std::min(n, (c + 1) * kChunk), parts[c]); });
  std::size_t total = 0;
  for (const auto& p : parts) total += p.size();
  out.reserve(total);
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
}

std::string row_text(const char* call, std::size_t row) {
  return std::string("BroadPhase::") + call + ": row " + std::to_string(row) + ": ";
}

}  // namespace

struct BroadPhase::Impl {
  explicit Impl(const BroadPhaseOptions& o)
      : options(o),
        arena(detail::arena_threads(o.threads)),
        hybrid(hybrid_options(o)) {
    collide_mask.fill(0xFFFFFFFFu);
  }

  static BroadPhaseOptions hybrid_options(BroadPhaseOptions o) {
    o.sorted = true;
    return o;
  }

  BroadPhaseOptions options;
  tbb::task_arena arena;
  HybridBroadPhase hybrid;

  HandleTable table;
  // By slot: the box of a static object, and of a moving object until it
  // has a dense index (then its box is moving_boxes[index], written back
  // here when the moving membership changes: see box_of and sync_moving).
  std::vector<Aabb> slot_box;

  // Moving objects, dense, ordered by handle; every box screened as it is
  // written (ScreenedBoxes), so the hybrid system takes them as
  // ValidatedBoxes without a screen of its own.
  detail::ScreenedBoxes moving_boxes;
  std::vector<Handle> moving_handle;
  bool moving_identity = false;  // moving_handle[d] == d for every d (no remapping)
  bool moving_membership_dirty = false;
  // Their pairs from fat-box candidates while few move (else the hybrid system).
  FatMovingPairs fat_moving;
  std::vector<Pair> fat_moving_pairs;

  // Static objects, dense, ordered by handle, and their tree.
  BoxArray static_boxes;
  std::vector<Handle> static_handle;
  BoxTree static_tree;
  bool statics_dirty = false;
  std::uint32_t static_epoch = 1;  // advanced at each static rebuild

  // Moving vs static candidates, by slot: valid while epoch == static_epoch
  // and the object's box stays inside `fat`. The candidates' boxes are
  // copied in, so a frame's re-test reads one contiguous list per object
  // instead of six scattered static lanes per candidate.
  struct Candidate {
    Aabb box;
    Handle handle;
    std::uint32_t hit;  // overlapped at the last frame (kept when the pairs are unfiltered)
  };
  // Per moving object, by dense index (moved along when the dense order
  // changes, so the memory follows the moving objects, not the slots):
  // `fat` and `epoch` say whether `list` is valid (one record, so an object
  // that re-tests reads one line before its list); `lo`/`hi` are the quiet
  // box, one open interval per coordinate (0-2: box.min[k], 3-5:
  // box.max[k]): while lo < v < hi for all six the box crosses no
  // candidate's face and stays inside `fat`, so no candidate's overlap can
  // flip and a frame skips the list without reading it. (All zero: never
  // quiet.)
  struct ListEntry {
    Aabb fat;
    std::uint32_t epoch = 0;
    std::vector<Candidate> list;
  };
  struct StaticCaches {
    std::vector<ListEntry> entry;
    std::array<std::vector<float>, 6> lo, hi;

    std::size_t size() const { return entry.size(); }
    // New order: entry d is the old entry previous[d] (kNoIndex: a new object).
    void permute(std::span<const std::uint32_t> previous) {
      StaticCaches next;
      const std::size_t n = previous.size();
      next.entry.resize(n);
      for (int c = 0; c < 6; ++c) {
        next.lo[c].assign(n, 0.0f);
        next.hi[c].assign(n, 0.0f);
      }
      for (std::size_t d = 0; d < n; ++d) {
        const std::uint32_t o = previous[d];
        if (o == kNoIndex) continue;
        next.entry[d] = std::move(entry[o]);
        for (int c = 0; c < 6; ++c) {
          next.lo[c][d] = lo[c][o];
          next.hi[c][d] = hi[c][o];
        }
      }
      *this = std::move(next);
    }
  };
  StaticCaches cache;
  std::vector<std::uint32_t> previous_index;  // scratch of sync_moving

  // Moving objects' tree, for queries only.
  BoxTree moving_tree;
  enum class TreeState { Valid, Refit, Rebuild };
  TreeState moving_tree_state = TreeState::Rebuild;
  std::atomic<bool> queries_ready{false};
  std::mutex query_sync;

  std::array<std::uint32_t, kLayerCount> collide_mask{};
  PairFilter filter;

  // Results.
  BroadPhaseUpdate result;
  BroadPhaseUpdateStats stats;
  // Statics or the moving membership changed since the last completed
  // update(). Kept apart from statics_dirty / moving_membership_dirty, which
  // say whether the dense arrays are synchronised: a query synchronises them
  // too, and must not make the next update() take the incremental path.
  bool structure_changed = false;
  std::vector<Pair> moving_pairs, static_pairs, next, sort_scratch, flips;
  detail::PairDiffScratch diff_scratch;
  // static_pairs holds last frame's moving/static pairs and every cached
  // candidate's `hit` agrees with it: true after an unfiltered frame in
  // which nothing but moving boxes changed since.
  bool static_pairs_valid = false;
  // The stats' counts since the last completed update(): objects counted
  // once each, whatever the number of edits. An object is counted when an
  // edit first changes it (added, removed, or moved to a different box);
  // changed_serial[slot] == frame_serial marks it, except for the moving
  // objects a whole-frame move changed (see whole_frame_moved).
  std::uint32_t moved = 0, static_changes = 0;
  std::vector<std::uint32_t> changed_serial;
  std::uint32_t frame_serial = 1;
  // Objects whose kind changed this frame (set_static): serial ==
  // frame_serial marks them, and such an object is counted in
  // static_changes; moved_counted says whether it is in `moved` too. An
  // object with no such mark has had its kind all frame, and changed_serial
  // says whether the counter of that kind counts it. Sized by set_static
  // (a world that never changes kinds has none).
  struct KindChange {
    std::uint32_t serial = 0;
    bool moved_counted = false;
  };
  std::vector<KindChange> kind_changed;
  // The whole-frame move (move_every_moving) was this frame's first change
  // of a moving box: moving_boxes.replaced() holds the boxes before it, in
  // the same dense order, and the moving objects whose box differs from
  // theirs there are counted without a mark (marking them would cost the
  // fast path a write per object). Turned into marks before the dense order
  // changes.
  bool whole_frame_moved = false;

  // Duplicate detection within a batch.
  std::vector<std::uint32_t> stamp;
  std::uint32_t stamp_value = 0;

  // ---- edits -------------------------------------------------------------

  void touched_moving() {
    queries_ready = false;
    if (moving_tree_state == TreeState::Valid) moving_tree_state = TreeState::Refit;
  }
  void moving_membership_changed() {
    moving_membership_dirty = true;
    structure_changed = true;
    moving_tree_state = TreeState::Rebuild;
    queries_ready = false;
  }
  void statics_changed(std::uint32_t count) {
    statics_dirty = true;
    structure_changed = true;
    static_changes += count;
    queries_ready = false;
  }

  void size_change_marks() {
    if (changed_serial.size() < table.slots()) changed_serial.resize(table.slots(), 0);
  }
  // Moving object d (dense index) was changed by the whole-frame move.
  bool changed_by_whole_frame(std::uint32_t d) const {
    return whole_frame_moved && !same_box(moving_boxes.replaced().get(d), moving_boxes.get(d));
  }
  // Before the dense order changes: the whole-frame move's changes as marks.
  void mark_whole_frame_moves() {
    if (!whole_frame_moved) return;
    size_change_marks();
    for (std::uint32_t d = 0; d < moving_handle.size(); ++d)
      if (changed_by_whole_frame(d)) changed_serial[HandleTable::slot_of(moving_handle[d])] = frame_serial;
    whole_frame_moved = false;
  }
  // Marks slot s changed; true when it was not counted yet this frame.
  bool first_change(std::uint32_t s, std::uint32_t d) {
    const bool counted = changed_serial[s] == frame_serial || (d != kNoIndex && changed_by_whole_frame(d));
    changed_serial[s] = frame_serial;
    return !counted;
  }

  // Checks a batch of handles: live, no duplicates. Throws naming the row.
  void check_handles(const char* call, std::span<const Handle> handles) {
    if (stamp.size() < table.slots()) stamp.resize(table.slots(), 0);
    if (++stamp_value == 0) {
      std::fill(stamp.begin(), stamp.end(), 0);
      stamp_value = 1;
    }
    for (std::size_t i = 0; i < handles.size(); ++i) {
      const std::string why = table.defect(handles[i]);
      if (!why.empty()) throw InvalidInput(row_text(call, i) + why);
      const std::uint32_t s = HandleTable::slot_of(handles[i]);
      if (stamp[s] == stamp_value) {
        const auto first = std::find(handles.begin(), handles.end(), handles[i]) - handles.begin();
        throw InvalidInput(row_text(call, i) + "handle " + std::to_string(handles[i]) + " repeats row " +
                           std::to_string(first));
      }
      stamp[s] = stamp_value;
    }
  }

  static void check_boxes(const char* call, std::span<const Aabb> boxes) {
    for (std::size_t i = 0; i < boxes.size(); ++i)
      if (const char* d = box_defect(boxes[i])) throw InvalidInput(row_text(call, i) + d);
  }

  std::vector<Handle> add(std::span<const Aabb> boxes, const AddOptions& o) {
    if (o.layer >= kLayerCount)
      throw InvalidInput("BroadPhase::add: layer " + std::to_string(o.layer) + " out of range (0.." +
                         std::to_string(kLayerCount - 1) + ")");
    if (boxes.size() > kMaxObjects - table.live())
      throw InvalidInput("BroadPhase::add: " + std::to_string(boxes.size()) + " objects on top of " +
                         std::to_string(table.live()) + " would pass the limit of " + std::to_string(kMaxObjects) +
                         " objects");
    check_boxes("add", boxes);
    if (!o.is_static && !boxes.empty()) mark_whole_frame_moves();
    std::vector<Handle> handles(boxes.size());
    const auto kind = o.is_static ? HandleTable::kStatic : HandleTable::kMoving;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const std::uint32_t s = table.allocate(kind, o.layer);
      if (s >= slot_box.size()) slot_box.resize(s + 1);
      slot_box[s] = boxes[i];
      handles[i] = table.handle_of(s);
    }
    size_change_marks();
    for (const Handle h : handles) {
      changed_serial[HandleTable::slot_of(h)] = frame_serial;  // a slot reused this frame counts again
      if (HandleTable::slot_of(h) < kind_changed.size()) kind_changed[HandleTable::slot_of(h)] = {};
    }
    if (boxes.empty()) return handles;
    if (o.is_static) {
      statics_changed(static_cast<std::uint32_t>(boxes.size()));
    } else {
      moving_membership_changed();
      moved += static_cast<std::uint32_t>(boxes.size());
    }
    return handles;
  }

  // Screens for the common batch: handles strictly increasing (so none
  // repeats) and live (here), boxes well formed (geometry::screen_fails).
  // One branch-free pass each; when a screen fails, the row-by-row checks
  // above name the offending row.
  bool handles_increasing_and_live(const Handle* h, std::size_t begin, std::size_t end) const {
    bool ok = true;
    Handle last = begin ? h[begin - 1] : 0;
    for (std::size_t i = begin; i < end; ++i) {
      ok &= table.live(h[i]) & (i == 0 || h[i] > last);
      last = h[i];
    }
    return ok;
  }



  // Runs body(begin, end) over ranges of [0, n), in parallel on the broad
  // phase's threads when the batch is large; returns the sum of the
  // results (integer counts: the same for any split).
  template <class Result, class Body>
  Result for_batch(std::size_t n, Body&& body) {
    constexpr std::size_t kEdits = 16384;  // edits per parallel task
    if (n < 2 * kEdits) return body(std::size_t(0), n);
    return arena.execute([&] {
      return tbb::parallel_reduce(
          tbb::blocked_range<std::size_t>(0, n, kEdits), Result{},
          [&](const tbb::blocked_range<std::size_t>& r, Result sum) { return sum + body(r.begin(), r.end()); },
          [](const Result& a, const Result& b) { return a + b; });
    });
  }

  // What a general move() batch changed: objects counted for the stats
  // (first change this frame) and rows that changed a box at all.
  struct MoveCounts {
    std::uint32_t moving_first = 0, moving_changed = 0, static_first = 0, static_changed = 0;
    MoveCounts operator+(const MoveCounts& o) const {
      return {moving_first + o.moving_first, moving_changed + o.moving_changed, static_first + o.static_first,
              static_changed + o.static_changed};
    }
  };

  // The whole-frame batch: every moving object, in handle (= dense) order,
  // with no membership change pending and no moving box changed yet this
  // frame. One pass compares the handles with moving_handle, checks each
  // box, counts the changed ones and writes it into a staging array, which
  // then replaces moving_boxes (ScreenedBoxes::transpose): the input is read
  // once and nothing is written in place, so a failed row (false: the
  // general path below then names it) leaves everything as it was.
  bool move_every_moving(const Handle* h, const Aabb* b, std::size_t n) {
    if (moving_membership_dirty || n == 0 || n != moving_handle.size() || moved != 0 || whole_frame_moved)
      return false;
    // With handles equal to dense indices the expected handle is i itself
    // (no second handle array to read).
    const Handle* want = moving_identity ? nullptr : moving_handle.data();
    // A batch this large (6 MB of boxes) does not stay in cache until
    // update() reads it: non-temporal stores save reading every line first.
    // A small batch keeps plain stores: its lines are still in L2 for
    // update().
    constexpr std::size_t kStreamBoxes = std::size_t{1} << 18;
    const bool stream = n >= kStreamBoxes;
    std::uint32_t changed = 0;
    const auto ranges = [&](std::size_t count, auto&& body) { return for_batch<std::uint64_t>(count, body); };
    if (!moving_boxes.transpose(b, h, want, n, stream, ranges, changed)) return false;
    whole_frame_moved = true;
    moved += changed;
    if (changed) touched_moving();
    return true;
  }

  void move(std::span<const Handle> handles, std::span<const Aabb> boxes) {
    if (handles.size() != boxes.size())
      throw InvalidInput("BroadPhase::move: " + std::to_string(handles.size()) + " handles but " +
                         std::to_string(boxes.size()) + " boxes");
    const std::size_t n = handles.size();
    const Handle* h = handles.data();
    const Aabb* b = boxes.data();
    if (move_every_moving(h, b, n)) return;
    // Ranges whose handles failed the screen in the low 32 bits, whose
    // boxes did in the high 32.
    const std::uint64_t failed = for_batch<std::uint64_t>(n, [&](std::size_t begin, std::size_t end) {
      return std::uint64_t(!handles_increasing_and_live(h, begin, end)) |
             std::uint64_t(geometry::screen_fails(b, begin, end)) << 32;
    });
    if (failed & 0xFFFFFFFFu) check_handles("move", handles);
    if (failed >> 32) check_boxes("move", boxes);
    size_change_marks();
    // Distinct handles: the ranges write distinct slots and dense indices.
    // A box moved to its own value changes nothing.
    const MoveCounts c = for_batch<MoveCounts>(n, [&](std::size_t begin, std::size_t end) {
      MoveCounts part;
      for (std::size_t i = begin; i < end; ++i) {
        const std::uint32_t s = HandleTable::slot_of(h[i]);
        const bool is_static = table.kind(s) == HandleTable::kStatic;
        const std::uint32_t d = is_static ? kNoIndex : table.index(s);
        if (same_box(d != kNoIndex ? moving_boxes.get(d) : slot_box[s], b[i])) continue;
        const bool first = first_change(s, d);
        if (is_static) {
          slot_box[s] = b[i];
          part.static_first += first;
          ++part.static_changed;
        } else {
          if (d != kNoIndex)
            moving_boxes.set(d, b[i]);
          else
            slot_box[s] = b[i];
          part.moving_first += first;
          ++part.moving_changed;
        }
      }
      return part;
    });
    if (c.static_changed) statics_changed(c.static_first);
    if (c.moving_changed) touched_moving();
    moved += c.moving_first;
  }

  void remove(std::span<const Handle> handles) {
    check_handles("remove", handles);
    mark_whole_frame_moves();
    size_change_marks();
    std::uint32_t statics = 0, statics_first = 0, moving = 0;
    for (const Handle h : handles) {
      const std::uint32_t s = HandleTable::slot_of(h);
      if (table.kind(s) == HandleTable::kStatic) {
        ++statics;
        statics_first += first_change(s, kNoIndex);
      } else {
        ++moving;
      }
      table.release(s);
    }
    if (statics) statics_changed(statics_first);
    if (moving) moving_membership_changed();
    if (table.live() == 0) release_memory();
  }

  void set_layer(std::span<const Handle> handles, std::uint8_t layer) {
    if (layer >= kLayerCount)
      throw InvalidInput("BroadPhase::set_layer: layer " + std::to_string(layer) + " out of range (0.." +
                         std::to_string(kLayerCount - 1) + ")");
    check_handles("set_layer", handles);
    for (const Handle h : handles) table.set_layer(HandleTable::slot_of(h), layer);
    static_pairs_valid = false;
  }

  // ---- sleeping and waking -------------------------------------------------

  // A kind change is a membership change of both sets: the object leaves
  // the dense arrays of its old kind and joins the other's at the next
  // gather, keeping its slot (so its handle) and layer. Its box goes to
  // slot_box first, where both gathers read it. Stats: a sleeping object
  // counts as a static added, a waking one as a static removed and a moving
  // object added, each counter at most once per object per frame.
  void set_static(std::span<const Handle> handles, bool to_static) {
    check_handles("set_static", handles);
    const auto want = to_static ? HandleTable::kStatic : HandleTable::kMoving;
    bool any = false;
    for (const Handle h : handles) any |= table.kind(HandleTable::slot_of(h)) != want;
    if (!any) return;
    mark_whole_frame_moves();  // before the dense order changes
    size_change_marks();
    if (kind_changed.size() < table.slots()) kind_changed.resize(table.slots());
    std::uint32_t static_first = 0, moved_first = 0;
    for (const Handle h : handles) {
      const std::uint32_t s = HandleTable::slot_of(h);
      const auto kind = table.kind(s);
      if (kind == want) continue;
      if (kind == HandleTable::kMoving && table.index(s) != kNoIndex) slot_box[s] = moving_boxes.get(table.index(s));
      KindChange& k = kind_changed[s];
      bool static_counted, moved_counted;
      if (k.serial == frame_serial) {
        static_counted = true;
        moved_counted = k.moved_counted;
      } else {
        const bool counted = changed_serial[s] == frame_serial;
        static_counted = counted && kind == HandleTable::kStatic;
        moved_counted = counted && kind == HandleTable::kMoving;
      }
      static_first += !static_counted;
      if (!to_static) {
        moved_first += !moved_counted;
        moved_counted = true;
      }
      k = {frame_serial, moved_counted};
      changed_serial[s] = frame_serial;  // the new kind's counter counts it
      table.set_kind(s, want);
    }
    statics_changed(static_first);
    moving_membership_changed();
    moved += moved_first;
  }

  // With no objects left, nothing the next frames need is kept (the slot
  // table stays: its generations keep old handles stale).
  void release_memory() {
    moving_boxes.release();
    static_boxes = BoxArray();
    std::vector<Handle>().swap(moving_handle);
    std::vector<Handle>().swap(static_handle);
    static_tree.clear();
    moving_tree.clear();
    fat_moving.release();
    std::vector<Pair>().swap(fat_moving_pairs);
    cache = StaticCaches();
    std::vector<std::uint32_t>().swap(previous_index);
    static_pairs_valid = false;
  }

  // ---- structures ----------------------------------------------------------

  // Dense arrays of one kind, ordered by handle.
  // previous (if given): each object's old dense index (kNoIndex: new).
  void gather(HandleTable::Kind kind, BoxArray& boxes, std::vector<Handle>& handles,
              std::vector<std::uint32_t>* previous = nullptr) {
    handles.clear();
    for (std::uint32_t s = 0; s < table.slots(); ++s)
      if (table.kind(s) == kind) handles.push_back(table.handle_of(s));
    std::sort(handles.begin(), handles.end());
    retained::trim(handles);
    if (retained::oversized(boxes.capacity(), handles.size(), retained::kSlack<Aabb>)) boxes = BoxArray();
    boxes.resize(handles.size());
    if (previous) previous->resize(handles.size());
    for (std::uint32_t d = 0; d < handles.size(); ++d) {
      const std::uint32_t s = HandleTable::slot_of(handles[d]);
      if (previous) (*previous)[d] = table.index(s);
      boxes.set(d, slot_box[s]);
      table.set_index(s, d);
    }
  }

  void sync_statics() {
    if (!statics_dirty) return;
    gather(HandleTable::kStatic, static_boxes, static_handle);
    if (static_handle.empty()) {
      static_tree.clear();
    } else {
      static_tree.build(static_boxes, static_handle);
    }
    ++static_epoch;
    statics_dirty = false;
  }

  // The box of a live slot (see slot_box).
  Aabb box_of(std::uint32_t s) const {
    const std::uint32_t d = table.index(s);
    return table.kind(s) == HandleTable::kMoving && d != kNoIndex ? moving_boxes.get(d) : slot_box[s];
  }

  void sync_moving() {
    if (!moving_membership_dirty) return;
    // The indexed moving objects' boxes back into slot_box, which gather reads.
    for (std::uint32_t s = 0; s < table.slots(); ++s)
      if (table.kind(s) == HandleTable::kMoving && table.index(s) != kNoIndex)
        slot_box[s] = moving_boxes.get(table.index(s));
    BoxArray gathered = moving_boxes.take();
    gather(HandleTable::kMoving, gathered, moving_handle, &previous_index);
    moving_boxes.assign(std::move(gathered));
    cache.permute(previous_index);
    retained::trim(previous_index);
    fat_moving.reset();
    moving_boxes.trim_staging(moving_handle.size());
    // Strictly increasing handles from 0 ending at size - 1 are 0, 1, 2 ...
    moving_identity = !moving_handle.empty() && moving_handle.back() == moving_handle.size() - 1;
    moving_membership_dirty = false;
  }

  void sync_queries() {
    if (queries_ready.load(std::memory_order_acquire)) return;
    std::lock_guard<std::mutex> lock(query_sync);
    if (queries_ready.load(std::memory_order_relaxed)) return;
    arena.execute([&] {
      sync_statics();
      sync_moving();
      if (moving_handle.empty()) {
        moving_tree.clear();
      } else if (moving_tree_state == TreeState::Rebuild) {
        moving_tree.build(moving_boxes.boxes(), moving_handle);
      } else if (moving_tree_state == TreeState::Refit) {
        moving_tree.refit(moving_boxes.boxes());
      }
      moving_tree_state = TreeState::Valid;
    });
    queries_ready.store(true, std::memory_order_release);
  }

  // ---- a frame ------------------------------------------------------------

  bool layers_collide(Handle a, Handle b) const {
    const std::uint8_t la = table.layer(HandleTable::slot_of(a));
    const std::uint8_t lb = table.layer(HandleTable::slot_of(b));
    return (collide_mask[la] >> lb) & 1u;
  }

  // A frame's pair count against options.max_pairs (0: unlimited).
  void check_max_pairs(std::size_t pairs) const {
    if (options.max_pairs && pairs > options.max_pairs)
      throw CapacityExceeded("BroadPhase::update: " + std::to_string(pairs) + " pairs, more than max_pairs " +
                             std::to_string(options.max_pairs));
  }

  bool all_layers_collide() const {
    for (const std::uint32_t m : collide_mask)
      if (m != 0xFFFFFFFFu) return false;
    return true;
  }

  void find_moving_pairs() {
    moving_pairs.clear();
    if (moving_handle.size() < 2) return;
    const std::vector<Pair>& raw = fat_moving.find(moving_boxes.boxes(), hybrid, options.max_pairs, fat_moving_pairs)
                                       ? fat_moving_pairs
                                       : hybrid.update(moving_boxes.view());
    const Handle* h = moving_handle.data();
    if (all_layers_collide() && !filter) {
      moving_pairs.resize(raw.size());
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, raw.size(), kChunk), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) moving_pairs[i] = Pair{h[raw[i].a], h[raw[i].b]};
      });
      return;
    }
    parallel_collect(raw.size(), moving_pairs, [&](std::size_t begin, std::size_t end, std::vector<Pair>& out) {
      for (std::size_t i = begin; i < end; ++i) {
        const Pair p{h[raw[i].a], h[raw[i].b]};
        if (layers_collide(p.a, p.b) && (!filter || filter(p.a, p.b))) out.push_back(p);
      }
    });
  }

  // Rebuilds moving object d's candidate list from the static tree.
  void requery(std::size_t d, const Aabb& box, std::uint32_t epoch) {
    ListEntry& e = cache.entry[d];
    e.fat = fat_box(box);
    e.epoch = epoch;
    std::vector<Candidate>& list = e.list;
    list.clear();
    static_tree.for_each_overlap(e.fat, [&](std::uint32_t i, const auto& leaf) {
      list.push_back({{{leaf.min[0], leaf.min[1], leaf.min[2]}, {leaf.max[0], leaf.max[1], leaf.max[2]}},
                      static_handle[i], 0});
    });
    retained::trim(list, kCandidateSlack);
  }

  // Re-tests d's candidates against `box` (seen(candidate, hit) for each)
  // and sets d's quiet box around `box`, in one pass over the list. A
  // candidate's overlap is six conditions (box.min[k] <= c.max[k],
  // box.max[k] >= c.min[k]); it cannot change while the conditions it
  // depends on keep their values: all six for an overlapping candidate, and
  // for a separated one just one false condition (the widest gap), which
  // keeps it separated whatever the others do. Each kept condition bounds
  // one coordinate of the box; the quiet box is the intersection, and the
  // fat box (the list's validity).
  template <class Seen>
  void retest(std::size_t d, const Aabb& box, Seen&& seen) {
    constexpr float inf = std::numeric_limits<float>::infinity();
    // Closed bounds first: min[k] in (lo, hi], max[k] in [lo, hi).
    float lo[6], hi[6];
    for (int k = 0; k < 6; ++k) {
      lo[k] = -inf;
      hi[k] = inf;
    }
    for (Candidate& q : cache.entry[d].list) {
      // Condition c false (c < 3: box.min[c] > q.max[c]; else box.max[c-3]
      // < q.min[c-3]) by gap[c] > 0; the comparisons decide, the gaps only
      // rank.
      int widest = -1;
      float widest_gap = 0;
      for (int k = 0; k < 3; ++k) {
        const float g0 = box.min[k] - q.box.max[k], g1 = q.box.min[k] - box.max[k];
        if (box.min[k] > q.box.max[k] && (widest < 0 || g0 > widest_gap)) {
          widest = k;
          widest_gap = g0;
        }
        if (box.max[k] < q.box.min[k] && (widest < 0 || g1 > widest_gap)) {
          widest = 3 + k;
          widest_gap = g1;
        }
      }
      seen(q, static_cast<std::uint32_t>(widest < 0));
      if (widest >= 0) {  // separated: keep that condition false
        if (widest < 3) {
          lo[widest] = std::max(lo[widest], q.box.max[widest]);
        } else {
          hi[widest] = std::min(hi[widest], q.box.min[widest - 3]);
        }
        continue;
      }
      for (int k = 0; k < 3; ++k) {  // overlapping: keep all six true
        hi[k] = std::min(hi[k], q.box.max[k]);
        lo[3 + k] = std::max(lo[3 + k], q.box.min[k]);
      }
    }
    // Open intervals (v is a float: v <= h iff v < next float above h), and
    // inside the fat box: min[k] >= fat.min[k], max[k] <= fat.max[k].
    const Aabb& fat = cache.entry[d].fat;
    for (int k = 0; k < 3; ++k) {
      cache.lo[k][d] = std::max(lo[k], next_down(fat.min[k]));
      cache.hi[k][d] = next_up(hi[k]);
      cache.lo[3 + k][d] = next_down(lo[3 + k]);
      cache.hi[3 + k][d] = std::min(hi[3 + k], next_up(fat.max[k]));
    }
  }

  // Appends to busy the objects of [begin, end) outside their quiet box.
  std::size_t collect_busy(std::size_t begin, std::size_t end, std::uint32_t* busy) const {
    const BoxArray& mb = moving_boxes.boxes();
    const float* v[6] = {mb.min(0), mb.min(1), mb.min(2), mb.max(0), mb.max(1), mb.max(2)};
    const float* lo[6];
    const float* hi[6];
    for (int c = 0; c < 6; ++c) {
      lo[c] = cache.lo[c].data();
      hi[c] = cache.hi[c].data();
    }
    std::size_t n_busy = 0;
    std::size_t d = begin;
#if defined(__SSE2__)
    for (; d + 4 <= end; d += 4) {
      __m128 q = _mm_castsi128_ps(_mm_set1_epi32(-1));
      for (int c = 0; c < 6; ++c) {
        const __m128 x = _mm_loadu_ps(v[c] + d);
        q = _mm_and_ps(q, _mm_and_ps(_mm_cmplt_ps(_mm_loadu_ps(lo[c] + d), x), _mm_cmplt_ps(x, _mm_loadu_ps(hi[c] + d))));
      }
      for (unsigned bits = ~static_cast<unsigned>(_mm_movemask_ps(q)) & 15u; bits; bits &= bits - 1)
        busy[n_busy++] = static_cast<std::uint32_t>(d + static_cast<std::size_t>(__builtin_ctz(bits)));
    }
#endif
    for (; d < end; ++d) {
      bool q = true;
      for (int c = 0; c < 6; ++c) q &= (lo[c][d] < v[c][d]) & (v[c][d] < hi[c][d]);
      if (!q) busy[n_busy++] = static_cast<std::uint32_t>(d);
    }
    return n_busy;
  }

  // The moving/static pairs. `incremental` (unfiltered, and since the last
  // frame only moving boxes changed): only the candidates whose overlap
  // flipped are collected, sorted (a few hundred a frame) and XOR-merged
  // into last frame's sorted list, instead of re-collecting and re-sorting
  // every pair.
  void find_static_pairs(bool incremental) {
    const bool valid_before = static_pairs_valid;
    static_pairs_valid = false;
    if (moving_handle.empty() || static_handle.empty()) {
      static_pairs.clear();
      return;
    }
    const bool all = all_layers_collide();
    const std::uint32_t epoch = static_epoch;
    if (incremental && valid_before && all && !filter) {
      parallel_collect(moving_handle.size(), flips, [&](std::size_t begin, std::size_t end, std::vector<Pair>& out) {
        // Pass 1 keeps the objects whose box left its quiet box (a few in
        // ten); pass 2 re-tests their lists, prefetched a few objects ahead
        // because the lists are scattered on the heap and mostly cold.
        std::uint32_t busy[kChunk];
        const std::size_t n_busy = collect_busy(begin, end, busy);
        constexpr std::size_t kAhead = 4;
        auto prefetch = [&](std::size_t j) {
          const auto& list = cache.entry[busy[j]].list;
          const char* first = reinterpret_cast<const char*>(list.data());
          const char* last = reinterpret_cast<const char*>(list.data() + list.size());
          for (const char* q = first; q < last && q < first + 512; q += 64) __builtin_prefetch(q);
        };
        for (std::size_t j = 0; j < std::min(kAhead, n_busy); ++j) prefetch(j);
        for (std::size_t j = 0; j < n_busy; ++j) {
          if (j + kAhead < n_busy) prefetch(j + kAhead);
          const std::size_t d = busy[j];
          const Handle hm = moving_handle[d];
          const Aabb box = moving_boxes.get(d);
          ListEntry& e = cache.entry[d];
          std::vector<Candidate>& list = e.list;
          if (e.epoch == epoch && inside(box, e.fat)) {
            retest(d, box, [&](Candidate& k, std::uint32_t hit) {
              if (hit != k.hit) {  // rare: the pair starts or stops here
                k.hit = hit;
                out.push_back(make_pair(hm, k.handle));
              }
            });
            continue;
          }
          // Left its fat box: the pairs it had, then the pairs it has; a
          // pair in both cancels in the XOR merge below.
          for (const Candidate& k : list)
            if (k.hit) out.push_back(make_pair(hm, k.handle));
          requery(d, box, epoch);
          retest(d, box, [&](Candidate& k, std::uint32_t hit) {
            k.hit = hit;
            if (hit) out.push_back(make_pair(hm, k.handle));
          });
        }
      });
      sort_pairs(flips, sort_scratch);
      // static_pairs XOR flips (a pair flipped twice cancels).
      next.resize(static_pairs.size() + flips.size());
      Pair* o = next.data();
      const Pair *p = static_pairs.data(), *p_end = p + static_pairs.size();
      const Pair *f = flips.data(), *f_end = f + flips.size();
      while (f != f_end) {
        if (f + 1 != f_end && f[0] == f[1]) {
          f += 2;
          continue;
        }
        while (p != p_end && *p < *f) *o++ = *p++;
        if (p != p_end && *p == *f) {
          ++p;
        } else {
          *o++ = *f;
        }
        ++f;
      }
      o = std::copy(p, p_end, o);
      next.resize(static_cast<std::size_t>(o - next.data()));
      static_pairs.swap(next);
      retained::trim(flips);
      retained::trim(sort_scratch);
      static_pairs_valid = true;
      return;
    }
    static_pairs.clear();
    parallel_collect(moving_handle.size(), static_pairs,
                     [&](std::size_t begin, std::size_t end, std::vector<Pair>& out) {
                       for (std::size_t d = begin; d < end; ++d) {
                         const Handle hm = moving_handle[d];
                         const Aabb box = moving_boxes.get(d);
                         const ListEntry& e = cache.entry[d];
                         if (e.epoch != epoch || !inside(box, e.fat)) requery(d, box, epoch);
                         std::vector<Candidate>& list = cache.entry[d].list;
                         if (all && !filter) {
                           // Branch-free: about half the candidates overlap.
                           std::size_t size = out.size();
                           out.resize(size + list.size());
                           retest(d, box, [&](Candidate& k, std::uint32_t hit) {
                             k.hit = hit;
                             out[size] = make_pair(hm, k.handle);
                             size += hit;
                           });
                           out.resize(size);
                           continue;
                         }
                         for (const Candidate& k : list) {
                           if (!overlaps(box, k.box)) continue;
                           const Pair p = make_pair(hm, k.handle);
                           if (!all && !layers_collide(p.a, p.b)) continue;
                           if (filter && !filter(p.a, p.b)) continue;
                           out.push_back(p);
                         }
                       }
                     });
    parallel_sort_pairs(static_pairs, sort_scratch, arena);  // the whole moving/static list
    retained::trim(sort_scratch);
    static_pairs_valid = all && !filter;
  }

  // No static objects, no filtering: the frame's pairs are the hybrid
  // system's. Its boxes were all checked by add/move, so it skips its own
  // screen; with handles equal to dense indices its pair list is taken as
  // the result without a copy (the previous list's storage goes back to it),
  // else the indices are mapped to handles in the same parallel pass as the
  // merge with the previous frame.
  void all_moving_frame() {
    static const std::vector<Pair> none;
    const std::vector<Pair>& raw =
        moving_handle.size() >= 2 ? hybrid.update(moving_boxes.view()) : none;
    check_max_pairs(raw.size());
    moving_pairs.clear();
    static_pairs.clear();
    static_pairs_valid = false;
    if (&raw == &none) {
      detail::diff_sorted_pairs(result.pairs, none, result.created, result.removed, diff_scratch);
      result.pairs.clear();
    } else if (moving_identity) {
      detail::diff_sorted_pairs(result.pairs, raw, result.created, result.removed, diff_scratch);
      hybrid.swap_pairs(result.pairs);
    } else {
      detail::map_and_diff_sorted_pairs(result.pairs, raw, moving_handle.data(), next, result.created,
                                        result.removed, diff_scratch);
      result.pairs.swap(next);
    }
  }

  const BroadPhaseUpdate& update() {
    const auto start = SteadyClock::now();
    arena.execute([&] {
      // Only moving boxes changed since the last frame (no membership,
      // static or layer change): the moving/static pairs can be updated.
      const bool incremental = !structure_changed;
      sync_statics();
      sync_moving();
      if (static_handle.empty() && all_layers_collide() && !filter) {
        all_moving_frame();
        return;
      }
      find_moving_pairs();
      find_static_pairs(incremental);
      if (static_pairs.empty()) {
        next.swap(moving_pairs);
      } else if (moving_pairs.empty()) {
        next.assign(static_pairs.begin(), static_pairs.end());  // static_pairs is kept for the next frame
      } else {
        next.resize(moving_pairs.size() + static_pairs.size());
        std::merge(moving_pairs.begin(), moving_pairs.end(), static_pairs.begin(), static_pairs.end(), next.begin());
      }
      check_max_pairs(next.size());
      detail::diff_sorted_pairs(result.pairs, next, result.created, result.removed, diff_scratch);
      result.pairs.swap(next);
    });
    structure_changed = false;  // only once the frame is complete: a frame that throws is not applied
    retained::trim(next);
    retained::trim(moving_pairs);
    retained::trim(static_pairs);
    retained::trim(result.pairs);
    retained::trim(result.created);
    retained::trim(result.removed);
    stats.moving = static_cast<std::uint32_t>(moving_handle.size());
    stats.statics = static_cast<std::uint32_t>(static_handle.size());
    stats.moved = moved;
    stats.static_changes = static_changes;
    moved = static_changes = 0;
    whole_frame_moved = false;
    if (++frame_serial == 0) {  // after 2^32 frames: no mark may look current
      std::fill(changed_serial.begin(), changed_serial.end(), 0u);
      std::fill(kind_changed.begin(), kind_changed.end(), KindChange{});
      frame_serial = 1;
    }
    stats.wall_ms = ms_since(start);
    return result;
  }

  // ---- queries -------------------------------------------------------------

  // Box hits are written straight into `out` (cleared first): a caller that
  // keeps its vector pays no allocation once it is large enough.
  void query_box(const Aabb& q, std::vector<Handle>& out) {
    if (const char* d = box_defect(q)) throw InvalidInput(std::string("BroadPhase::query_box: ") + d);
    sync_queries();
    out.clear();
    const auto collect = [&](std::uint32_t, const BoxTree::Item& it) { out.push_back(it.id); };
    static_tree.for_each_overlap(q, collect);
    moving_tree.for_each_overlap(q, collect);
    std::sort(out.begin(), out.end());
  }

  // Ray hits are sorted by entry t in a per-thread scratch (no growth
  // reallocations per query), then their handles written into `out`.
  void query_ray(const float origin[3], const float direction[3], float max_t, std::vector<Handle>& out) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(origin[k]))
        throw InvalidInput("BroadPhase::query_ray: origin[" + std::to_string(k) + "] is not finite");
      if (!std::isfinite(direction[k]))
        throw InvalidInput("BroadPhase::query_ray: direction[" + std::to_string(k) + "] is not finite");
    }
    if (!(max_t >= 0)) throw InvalidInput("BroadPhase::query_ray: max_t must be >= 0 (infinity allowed)");
    sync_queries();
    const detail::RaySegment ray(origin, direction, max_t);
    struct Hit {
      float t;
      Handle h;
    };
    thread_local std::vector<Hit> hits;
    hits.clear();
    const auto collect = [&](const BoxTree::Item& it, float t) { hits.push_back({t, it.id}); };
    static_tree.for_each_ray_hit(ray, collect);
    moving_tree.for_each_ray_hit(ray, collect);
    std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.t < b.t || (a.t == b.t && a.h < b.h); });
    out.resize(hits.size());
    for (std::size_t i = 0; i < hits.size(); ++i) out[i] = hits[i].h;
    retained::trim(hits);
  }

  // ---- snapshots ------------------------------------------------------------

  // Calls f(slot, whether its kind changed, whether it is then counted in
  // `moved`) for each live slot the pending stats count already (see
  // changed_serial and kind_changed), in slot order.
  template <class F>
  void for_each_counted(F&& f) const {
    for (std::uint32_t s = 0; s < table.slots(); ++s) {
      if (table.kind(s) == HandleTable::kFree) continue;
      const std::uint32_t d = table.kind(s) == HandleTable::kMoving ? table.index(s) : kNoIndex;
      const bool counted = (s < changed_serial.size() && changed_serial[s] == frame_serial) ||
                           (d != kNoIndex && changed_by_whole_frame(d));
      if (!counted) continue;
      const bool kind_change = s < kind_changed.size() && kind_changed[s].serial == frame_serial;
      f(s, kind_change, kind_change && kind_changed[s].moved_counted);
    }
  }

  // The state as write_snapshot reads it: views of the table and the
  // results, boxes by box_of; only the stats' marks are collected.
  detail::SnapshotSource source() const {
    detail::SnapshotSource src;
    src.kind = table.kinds();
    src.generation = table.generations();
    src.layer = table.layer_table();
    src.free_slots = table.free_slots();
    src.box = [this](std::uint32_t s) { return box_of(s); };
    src.collide_mask = collide_mask;
    src.last = &result;
    src.stats = stats;
    src.pending_moved = moved;
    src.pending_static_changes = static_changes;
    for_each_counted([&](std::uint32_t s, bool kind_change, bool moved_counted) {
      src.counted.push_back(s);
      if (!kind_change) return;
      src.kind_changed.push_back(s);
      src.kind_changed_moved.push_back(moved_counted);
    });
    return src;
  }

  detail::SnapshotShape snapshot_shape() const {
    detail::SnapshotShape shape{.slots = table.slots(),
                                .free_slots = table.free_slots().size(),
                                .pairs = result.pairs.size(),
                                .created = result.created.size(),
                                .removed = result.removed.size()};
    for_each_counted([&](std::uint32_t, bool kind_change, bool) {
      ++shape.counted;
      shape.kind_changed += kind_change;
    });
    return shape;
  }

  // Takes a state read_snapshot checked, into a fresh Impl: every derived
  // structure is rebuilt from it at the next update or query, exactly as
  // after the same edits.
  void assign(detail::BroadPhaseState&& st) {
    table.assign(std::move(st.kind), std::move(st.generation), std::move(st.layer), std::move(st.free_slots));
    slot_box = std::move(st.boxes);
    collide_mask = st.collide_mask;
    result = std::move(st.last);
    stats = st.stats;
    moved = st.pending_moved;
    static_changes = st.pending_static_changes;
    // The marks' arrays only where there are marks (edits size them later).
    if (!st.counted.empty()) changed_serial.assign(table.slots(), 0);
    if (!st.kind_changed.empty()) kind_changed.assign(table.slots(), KindChange{});
    for (const std::uint32_t s : st.counted) changed_serial[s] = frame_serial;
    for (std::size_t i = 0; i < st.kind_changed.size(); ++i)
      kind_changed[st.kind_changed[i]] = {frame_serial, st.kind_changed_moved[i] != 0};
    statics_dirty = true;
    structure_changed = true;
    moving_membership_changed();
  }

  Handle checked(const char* call, Handle h) const {
    const std::string why = table.defect(h);
    if (!why.empty()) throw InvalidInput(std::string("BroadPhase::") + call + ": " + why);
    return h;
  }
};

BroadPhase::BroadPhase(const BroadPhaseOptions& options) : impl_(std::make_unique<Impl>(options)) {}
BroadPhase::~BroadPhase() = default;
BroadPhase::BroadPhase(BroadPhase&&) noexcept = default;
BroadPhase& BroadPhase::operator=(BroadPhase&&) noexcept = default;

std::vector<Handle> BroadPhase::add(std::span<const Aabb> boxes, const AddOptions& options) {
  return impl_->add(boxes, options);
}
void BroadPhase::reserve(std::size_t objects) {
  if (objects > kMaxObjects)
    throw InvalidInput("BroadPhase::reserve: " + std::to_string(objects) + " objects would pass the limit of " +
                       std::to_string(kMaxObjects) + " objects");
  Impl& m = *impl_;
  m.slot_box.reserve(objects);
  m.moving_boxes.reserve(objects);
  m.moving_handle.reserve(objects);
  m.hybrid.reserve(objects);
}
void BroadPhase::move(std::span<const Handle> handles, std::span<const Aabb> boxes) { impl_->move(handles, boxes); }
void BroadPhase::remove(std::span<const Handle> handles) { impl_->remove(handles); }
void BroadPhase::set_layer(std::span<const Handle> handles, std::uint8_t layer) {
  impl_->set_layer(handles, layer);
}

void BroadPhase::set_static(std::span<const Handle> handles, bool is_static) {
  impl_->set_static(handles, is_static);
}

// A snapshot reads what a query's synchronisation writes (dense indices and
// arrays): it holds the same lock, so it may run beside queries.
std::vector<std::byte> BroadPhase::snapshot() const {
  std::lock_guard<std::mutex> lock(impl_->query_sync);
  const detail::SnapshotSource source = impl_->source();
  std::vector<std::byte> out(detail::snapshot_size(detail::shape_of(source)));
  detail::write_snapshot(source, out);
  return out;
}
std::size_t BroadPhase::snapshot_size() const {
  std::lock_guard<std::mutex> lock(impl_->query_sync);
  return detail::snapshot_size(impl_->snapshot_shape());
}
std::size_t BroadPhase::snapshot(std::span<std::byte> out) const {
  std::lock_guard<std::mutex> lock(impl_->query_sync);
  const std::size_t size = detail::snapshot_size(impl_->snapshot_shape());
  if (out.size() < size)
    throw CapacityExceeded("BroadPhase::snapshot: a buffer of " + std::to_string(out.size()) +
                           " bytes, the snapshot needs " + std::to_string(size));
  detail::write_snapshot(impl_->source(), out);
  return size;
}
// Strong guarantee: the snapshot is read and checked whole, and the new
// state built in a fresh Impl, before it replaces the current one.
void BroadPhase::restore(std::span<const std::byte> data) {
  detail::BroadPhaseState state = detail::read_snapshot(data, "BroadPhase::restore");
  auto fresh = std::make_unique<Impl>(impl_->options);
  fresh->filter = impl_->filter;
  fresh->assign(std::move(state));
  impl_ = std::move(fresh);
}
BroadPhase BroadPhase::from_snapshot(std::span<const std::byte> data, const BroadPhaseOptions& options) {
  BroadPhase bp(options);
  bp.restore(data);
  return bp;
}

void BroadPhase::set_collides(std::uint32_t layer_a, std::uint32_t layer_b, bool collides) {
  if (layer_a >= kLayerCount || layer_b >= kLayerCount)
    throw InvalidInput("BroadPhase::set_collides: layer " + std::to_string(std::max(layer_a, layer_b)) +
                       " out of range (0.." + std::to_string(kLayerCount - 1) + ")");
  auto& m = impl_->collide_mask;
  if (collides) {
    m[layer_a] |= 1u << layer_b;
    m[layer_b] |= 1u << layer_a;
  } else {
    m[layer_a] &= ~(1u << layer_b);
    m[layer_b] &= ~(1u << layer_a);
  }
  impl_->static_pairs_valid = false;
}

bool BroadPhase::collides(std::uint32_t layer_a, std::uint32_t layer_b) const {
  if (layer_a >= kLayerCount || layer_b >= kLayerCount)
    throw InvalidInput("BroadPhase::collides: layer " + std::to_string(std::max(layer_a, layer_b)) +
                       " out of range (0.." + std::to_string(kLayerCount - 1) + ")");
  return (impl_->collide_mask[layer_a] >> layer_b) & 1u;
}

void BroadPhase::set_pair_filter(PairFilter filter) {
  impl_->filter = std::move(filter);
  impl_->static_pairs_valid = false;
}

const BroadPhaseUpdate& BroadPhase::update() { return impl_->update(); }
const BroadPhaseUpdate& BroadPhase::last_update() const { return impl_->result; }
const BroadPhaseUpdateStats& BroadPhase::stats() const { return impl_->stats; }

namespace {

// The hits of one query, visited in order. They are kept in a per-thread
// buffer taken out of its slot while the visitor runs: a visitor that runs a
// query itself finds the slot empty and uses its own buffer, so the list
// being visited is never overwritten. (A visitor that throws loses the
// buffer, not the result of any other query.)
template <class Query>
std::size_t visit_hits(const BroadPhase::HitVisitor& visit, Query query) {
  thread_local std::vector<Handle> slot;
  std::vector<Handle> hits;
  hits.swap(slot);
  query(hits);
  std::size_t calls = 0;
  for (const Handle h : hits) {
    ++calls;
    if (!visit(h)) break;
  }
  retained::trim(hits);
  if (hits.capacity() >= slot.capacity()) slot.swap(hits);
  return calls;
}

}  // namespace

Handle BroadPhase::add(const Aabb& box, const AddOptions& options) {
  return impl_->add(std::span<const Aabb>(&box, 1), options)[0];
}

// The vector-returning forms fill a per-thread scratch and copy it once into
// an answer of the exact size (no growth reallocations in the answer).
std::vector<Handle> BroadPhase::query_box(const Aabb& box) const {
  thread_local std::vector<Handle> scratch;
  impl_->query_box(box, scratch);
  std::vector<Handle> out(scratch.begin(), scratch.end());
  retained::trim(scratch);
  return out;
}
std::size_t BroadPhase::query_box(const Aabb& box, std::vector<Handle>& out) const {
  impl_->query_box(box, out);
  return out.size();
}
std::size_t BroadPhase::query_box(const Aabb& box, const HitVisitor& visit) const {
  return visit_hits(visit, [&](std::vector<Handle>& hits) { impl_->query_box(box, hits); });
}

std::vector<Handle> BroadPhase::query_ray(const float origin[3], const float direction[3], float max_t) const {
  thread_local std::vector<Handle> scratch;
  impl_->query_ray(origin, direction, max_t, scratch);
  std::vector<Handle> out(scratch.begin(), scratch.end());
  retained::trim(scratch);
  return out;
}
std::vector<Handle> BroadPhase::query_ray(const Vec3f& origin, const Vec3f& direction, float max_t) const {
  return query_ray(origin.data(), direction.data(), max_t);
}
std::size_t BroadPhase::query_ray(const Vec3f& origin, const Vec3f& direction, float max_t,
                                  std::vector<Handle>& out) const {
  impl_->query_ray(origin.data(), direction.data(), max_t, out);
  return out.size();
}
std::size_t BroadPhase::query_ray(const Vec3f& origin, const Vec3f& direction, float max_t,
                                  const HitVisitor& visit) const {
  return visit_hits(visit, [&](std::vector<Handle>& hits) { impl_->query_ray(origin.data(), direction.data(), max_t, hits); });
}

std::size_t BroadPhase::size() const { return impl_->table.live(); }
bool BroadPhase::contains(Handle h) const { return impl_->table.live(h); }
Aabb BroadPhase::box(Handle h) const {
  return impl_->box_of(HandleTable::slot_of(impl_->checked("box", h)));
}
bool BroadPhase::is_static(Handle h) const {
  return impl_->table.kind(HandleTable::slot_of(impl_->checked("is_static", h))) == HandleTable::kStatic;
}
std::uint8_t BroadPhase::layer(Handle h) const {
  return impl_->table.layer(HandleTable::slot_of(impl_->checked("layer", h)));
}
const BroadPhaseOptions& BroadPhase::options() const { return impl_->options; }

}  // namespace hbp
