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
// Double precision: the structures above hold each object's outward float
// box; the frame's pairs are confirmed on the double boxes before the event
// merge (see "large worlds" below).
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
#include "pipeline/box_cast.hpp"
#include "pipeline/frame_threads.hpp"
#include "pipeline/box_tree.hpp"
#include "pipeline/broad_phase_snapshot.hpp"
#include "pipeline/fat_moving_pairs.hpp"
#include "pipeline/handle_table.hpp"
#include "pipeline/outward_box.hpp"
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

// overlaps(a, b) as one expression: no branch per condition.
inline bool overlaps_branch_free(const Aabb& a, const Aabb& b) {
  return (a.max[0] >= b.min[0]) & (a.min[0] <= b.max[0]) & (a.max[1] >= b.min[1]) & (a.min[1] <= b.max[1]) &
         (a.max[2] >= b.min[2]) & (a.min[2] <= b.max[2]);
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
  detail::parallel_for_each(chunks, [&](std::size_t c) { body(c * kChunk, std::min(n, (c + 1) * kChunk), parts[c]); });
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
        arena(o.threads, o.task_system),
        hybrid(hybrid_options(o)) {
    collide_mask.fill(0xFFFFFFFFu);
  }

  static BroadPhaseOptions hybrid_options(BroadPhaseOptions o) {
    o.sorted = true;
    o.double_precision = false;  // the hybrid system gets the outward float boxes
    return o;
  }

  BroadPhaseOptions options;
  detail::FrameThreads arena;  // the engine's task system, or an own oneTBB arena
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

  // By slot: each object's Filter and user data (set at add, kept until the
  // slot is released). filtered_objects counts the live objects whose
  // filter is not the default (which accepts every default object): while
  // it is 0 no pair needs the filter test and the unfiltered paths hold.
  std::vector<Filter> slot_filter;
  std::vector<std::uint64_t> slot_user_data;
  std::uint32_t filtered_objects = 0;

  // Fast movers, by slot. slot_margin: grown onto every box the object is
  // given. A swept object (slot_swept) keeps in slot_end the box of its last
  // move_swept (grown), the "previous box" its next move_swept unions with,
  // so sweeps do not accumulate frame after frame; a plain move ends it.
  // While no object has a margin or is swept, move() keeps its whole-batch
  // path (margined_objects, swept_objects count the live ones).
  std::vector<float> slot_margin;
  std::vector<Aabb> slot_end;
  std::vector<std::uint8_t> slot_swept;
  std::uint32_t margined_objects = 0, swept_objects = 0;

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
    check_margin("add", o.margin);
    if (o.margin > 0)
      for (std::size_t i = 0; i < boxes.size(); ++i) check_grown("add", i, boxes[i], o.margin);
    if (!o.is_static && !boxes.empty()) mark_whole_frame_moves();
    std::vector<Handle> handles(boxes.size());
    const auto kind = o.is_static ? HandleTable::kStatic : HandleTable::kMoving;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const std::uint32_t s = table.allocate(kind, o.layer);
      if (s >= slot_box.size()) slot_box.resize(s + 1);
      slot_box[s] = grown(boxes[i], o.margin);
      handles[i] = table.handle_of(s);
      if (s >= slot_filter.size()) {
        slot_filter.resize(s + 1);
        slot_user_data.resize(s + 1);
        slot_margin.resize(s + 1);
        slot_end.resize(s + 1);
        slot_swept.resize(s + 1);
      }
      slot_margin[s] = o.margin;
      slot_swept[s] = 0;
      slot_filter[s] = o.filter;
      slot_user_data[s] = o.user_data;
    }
    if (o.margin > 0) margined_objects += static_cast<std::uint32_t>(boxes.size());
    if (!is_default(o.filter)) {
      filtered_objects += static_cast<std::uint32_t>(boxes.size());
      static_pairs_valid = false;
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
      return detail::parallel_reduce(
          n, kEdits, Result{}, [&](std::size_t begin, std::size_t end, Result sum) { return sum + body(begin, end); },
          [](const Result& a, const Result& b) { return a + b; });
    });
  }

  // What a general move() batch changed: objects counted for the stats
  // (first change this frame) and rows that changed a box at all.
  struct MoveCounts {
    std::uint32_t moving_first = 0, moving_changed = 0, static_first = 0, static_changed = 0;
    std::uint32_t swept_started = 0, swept_ended = 0;
    MoveCounts operator+(const MoveCounts& o) const {
      return {moving_first + o.moving_first,   moving_changed + o.moving_changed, static_first + o.static_first,
              static_changed + o.static_changed, swept_started + o.swept_started,   swept_ended + o.swept_ended};
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
    if (moving_membership_dirty || n == 0 || n != moving_handle.size() || moved != 0 || whole_frame_moved ||
        margined_objects != 0 || swept_objects != 0)
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

  // move() and move_swept(): `swept` sets each box to the union of the
  // object's previous box and the new one (both grown by its margin).
  void move(std::span<const Handle> handles, std::span<const Aabb> boxes, bool swept = false) {
    const char* call = swept ? "move_swept" : "move";
    if (handles.size() != boxes.size())
      throw InvalidInput(std::string("BroadPhase::") + call + ": " + std::to_string(handles.size()) +
                         " handles but " + std::to_string(boxes.size()) + " boxes");
    const std::size_t n = handles.size();
    const Handle* h = handles.data();
    const Aabb* b = boxes.data();
    if (!swept && move_every_moving(h, b, n)) return;
    // Ranges whose handles failed the screen in the low 32 bits, whose
    // boxes did in the high 32.
    const std::uint64_t failed = for_batch<std::uint64_t>(n, [&](std::size_t begin, std::size_t end) {
      return std::uint64_t(!handles_increasing_and_live(h, begin, end)) |
             std::uint64_t(geometry::screen_fails(b, begin, end)) << 32;
    });
    if (failed & 0xFFFFFFFFu) check_handles(call, handles);
    if (failed >> 32) check_boxes(call, boxes);
    if (margined_objects != 0)
      for (std::size_t i = 0; i < n; ++i) check_grown(call, i, b[i], slot_margin[HandleTable::slot_of(h[i])]);
    size_change_marks();
    // Distinct handles: the ranges write distinct slots and dense indices.
    // A box moved to its own value changes nothing.
    const MoveCounts c = for_batch<MoveCounts>(n, [&](std::size_t begin, std::size_t end) {
      MoveCounts part;
      for (std::size_t i = begin; i < end; ++i) {
        const std::uint32_t s = HandleTable::slot_of(h[i]);
        const bool is_static = table.kind(s) == HandleTable::kStatic;
        const std::uint32_t d = is_static ? kNoIndex : table.index(s);
        const Aabb current = d != kNoIndex ? moving_boxes.get(d) : slot_box[s];
        Aabb nb = grown(b[i], slot_margin[s]);
        if (swept) {
          const Aabb previous = slot_swept[s] ? slot_end[s] : current;
          slot_end[s] = nb;
          part.swept_started += !slot_swept[s];
          slot_swept[s] = 1;
          nb = united(previous, nb);
        } else if (slot_swept[s]) {
          slot_swept[s] = 0;
          ++part.swept_ended;
        }
        if (same_box(current, nb)) continue;
        const bool first = first_change(s, d);
        if (is_static) {
          slot_box[s] = nb;
          part.static_first += first;
          ++part.static_changed;
        } else {
          if (d != kNoIndex)
            moving_boxes.set(d, nb);
          else
            slot_box[s] = nb;
          part.moving_first += first;
          ++part.moving_changed;
        }
      }
      return part;
    });
    if (c.static_changed) statics_changed(c.static_first);
    if (c.moving_changed) touched_moving();
    moved += c.moving_first;
    swept_objects += c.swept_started - c.swept_ended;
  }

  static void check_margin(const char* call, float margin) {
    if (!(margin >= 0) || !std::isfinite(margin))
      throw InvalidInput(std::string("BroadPhase::") + call + ": margin " + std::to_string(margin) +
                         " must be finite and >= 0");
  }
  // The box grown by the margin on every side must stay finite.
  static void check_grown(const char* call, std::size_t row, const Aabb& b, float margin) {
    if (margin > 0 && box_defect(grown(b, margin)))
      throw InvalidInput(row_text(call, row) + "box grown by the margin " + std::to_string(margin) +
                         " is not finite");
  }
  static Aabb grown(const Aabb& b, float margin) {
    if (margin == 0) return b;
    Aabb g;
    for (int k = 0; k < 3; ++k) {
      g.min[k] = b.min[k] - margin;
      g.max[k] = b.max[k] + margin;
    }
    return g;
  }
  static Aabb united(const Aabb& a, const Aabb& b) {
    Aabb u;
    for (int k = 0; k < 3; ++k) {
      u.min[k] = std::min(a.min[k], b.min[k]);
      u.max[k] = std::max(a.max[k], b.max[k]);
    }
    return u;
  }

  // Margins and swept boxes grow the float boxes; a double-precision broad
  // phase confirms its pairs on the double boxes as given, so it has
  // neither (grow the AabbD instead).
  void require_float_margins(const char* call) const {
    if (options.double_precision)
      throw InvalidInput(std::string("BroadPhase::") + call +
                         ": margins and swept moves need float boxes (on a double_precision BroadPhase, grow the "
                         "AabbD boxes themselves)");
  }

  void set_margin(std::span<const Handle> handles, float margin) {
    require_float_margins("set_margin");
    check_margin("set_margin", margin);
    check_handles("set_margin", handles);
    for (const Handle h : handles) {
      const std::uint32_t s = HandleTable::slot_of(h);
      margined_objects += static_cast<std::uint32_t>(margin > 0) - (slot_margin[s] > 0);
      slot_margin[s] = margin;
    }
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
      filtered_objects -= !is_default(slot_filter[s]);
      margined_objects -= slot_margin[s] > 0;
      swept_objects -= slot_swept[s];
      slot_swept[s] = 0;
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

  void set_filter(std::span<const Handle> handles, const Filter& f) {
    check_handles("set_filter", handles);
    for (const Handle h : handles) {
      const std::uint32_t s = HandleTable::slot_of(h);
      filtered_objects += static_cast<std::uint32_t>(!is_default(f)) - !is_default(slot_filter[s]);
      slot_filter[s] = f;
    }
    static_pairs_valid = false;
  }

  void set_user_data(std::span<const Handle> handles, std::span<const std::uint64_t> values) {
    if (handles.size() != values.size())
      throw InvalidInput("BroadPhase::set_user_data: " + std::to_string(handles.size()) + " handles but " +
                         std::to_string(values.size()) + " values");
    check_handles("set_user_data", handles);
    for (std::size_t i = 0; i < handles.size(); ++i) slot_user_data[HandleTable::slot_of(handles[i])] = values[i];
  }

  // User data of a handle from a result list: 0 when it is no longer live
  // (a removed pair's object removed since).
  std::uint64_t user_data_or_zero(Handle h) const { return table.live(h) ? slot_user_data[HandleTable::slot_of(h)] : 0; }

  // Whether the object of handle h passes the query filter.
  bool passes(const QueryFilter& q, Handle h) const {
    const std::uint32_t s = HandleTable::slot_of(h);
    return ((q.layers_mask >> table.layer(s)) & 1u) && (slot_filter[s].category & q.category_mask) != 0;
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
    std::vector<AabbD>().swap(slot_box_d);
    std::vector<std::uint8_t>().swap(slot_exact);
    std::vector<Aabb>().swap(slot_inner);
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

  // No layer table, object filter or pair filter in force: every
  // overlapping pair is reported, and the frame takes its unfiltered paths
  // (the all-moving frame, the incremental moving/static pairs).
  bool unfiltered() const { return filtered_objects == 0 && !filter && all_layers_collide(); }

  // The layer table, then the objects' filters (b2Filter rule), then the
  // pair filter: a pair is stored only when all accept it.
  bool accepts(const Pair& p) const {
    const std::uint32_t sa = HandleTable::slot_of(p.a), sb = HandleTable::slot_of(p.b);
    if (!((collide_mask[table.layer(sa)] >> table.layer(sb)) & 1u)) return false;
    if (filtered_objects != 0 && !should_collide(slot_filter[sa], slot_filter[sb])) return false;
    return !filter || filter(p.a, p.b);
  }

  void find_moving_pairs() {
    moving_pairs.clear();
    if (moving_handle.size() < 2) return;
    const std::vector<Pair>& raw = fat_moving.find(moving_boxes.boxes(), hybrid, options.max_pairs, fat_moving_pairs)
                                       ? fat_moving_pairs
                                       : hybrid.update(moving_boxes.view());
    const Handle* h = moving_handle.data();
    if (unfiltered()) {
      moving_pairs.resize(raw.size());
      detail::parallel_for(raw.size(), kChunk, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i != end; ++i) moving_pairs[i] = Pair{h[raw[i].a], h[raw[i].b]};
      });
      return;
    }
    parallel_collect(raw.size(), moving_pairs, [&](std::size_t begin, std::size_t end, std::vector<Pair>& out) {
      for (std::size_t i = begin; i < end; ++i) {
        const Pair p{h[raw[i].a], h[raw[i].b]};
        if (accepts(p)) out.push_back(p);
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
    const bool all = unfiltered();
    const std::uint32_t epoch = static_epoch;
    if (incremental && valid_before && all) {
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
                         if (all) {
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
                           if (accepts(p)) out.push_back(p);
                         }
                       }
                     });
    parallel_sort_pairs(static_pairs, sort_scratch, arena);  // the whole moving/static list
    retained::trim(sort_scratch);
    static_pairs_valid = all;
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
      if (static_handle.empty() && unfiltered()) {
        if (!options.double_precision) {
          all_moving_frame();
          return;
        }
        all_moving_candidates();
      } else {
        find_moving_pairs();
        find_static_pairs(incremental);
        merge_found_pairs();
        check_max_pairs(next.size());
        if (options.double_precision) confirm(next, nullptr);
      }
      detail::diff_sorted_pairs(result.pairs, next, result.created, result.removed, diff_scratch);
      result.pairs.swap(next);
    });
    finish_update(start);
    return result;
  }

  // The frame's pairs into `next`: the moving/moving and moving/static
  // lists merged.
  void merge_found_pairs() {
    if (static_pairs.empty()) {
      next.swap(moving_pairs);
    } else if (moving_pairs.empty()) {
      next.assign(static_pairs.begin(), static_pairs.end());  // static_pairs is kept for the next frame
    } else {
      next.resize(moving_pairs.size() + static_pairs.size());
      std::merge(moving_pairs.begin(), moving_pairs.end(), static_pairs.begin(), static_pairs.end(), next.begin());
    }
  }

  void finish_update(SteadyClock::time_point start) {
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
  }

  // ---- large worlds --------------------------------------------------------
  //
  // Double precision (hbp/broad_phase.hpp): the float engine holds each
  // object's outward float box (outward_box.hpp), so its pairs are a superset
  // of the double boxes' pairs; confirm() keeps those whose double boxes
  // overlap before the frame's list is compared with the previous one.
  // By slot: the double box as given, and whether the outward box equals it
  // (then a pair of two such objects needs no double test). Written only
  // after the float edit succeeded, so a call that throws changes neither.
  // slot_inner: the inward float box (outward_box.hpp), the compact record
  // confirm() reads first.
  std::vector<AabbD> slot_box_d;
  std::vector<std::uint8_t> slot_exact;
  std::vector<Aabb> slot_inner;
  // The pair filter in double-precision mode, asked after the double test
  // (`filter` stays empty there, so the float engine keeps its fast paths).
  PairFilter confirm_filter;
  // Scratch of the double edits: a batch's outward and inward boxes and
  // exactness.
  std::vector<Aabb> outward, inward;
  std::vector<std::uint8_t> outward_exact;
  // Scratch of confirm(): pairs kept per chunk, and the compacted list.
  std::vector<std::size_t> confirm_kept;
  std::vector<Pair> confirm_scratch;

  void require_precision(const char* call, bool double_boxes) const {
    if (options.double_precision == double_boxes) return;
    throw InvalidInput(std::string("BroadPhase::") + call +
                       (double_boxes ? ": double boxes (AabbD) need options.double_precision"
                                     : ": float boxes (Aabb) on a double_precision BroadPhase (use AabbD)"));
  }

  static void check_boxes_d(const char* call, std::span<const AabbD> boxes) {
    for (std::size_t i = 0; i < boxes.size(); ++i)
      if (const char* d = box_defect(boxes[i])) throw InvalidInput(row_text(call, i) + d);
  }

  // outward / outward_exact for a batch of well-formed double boxes.
  void make_outward(std::span<const AabbD> boxes) {
    outward.resize(boxes.size());
    inward.resize(boxes.size());
    outward_exact.resize(boxes.size());
    for_batch<std::uint64_t>(boxes.size(), [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i)
        outward_exact[i] = detail::round_box(boxes[i], outward[i], inward[i]);
      return std::uint64_t(0);
    });
  }

  // After the float edit of `handles` (distinct, live) succeeded.
  void store_d(std::span<const Handle> handles, std::span<const AabbD> boxes) {
    for_batch<std::uint64_t>(handles.size(), [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const std::uint32_t s = HandleTable::slot_of(handles[i]);
        slot_box_d[s] = boxes[i];
        slot_exact[s] = outward_exact[i];
        slot_inner[s] = inward[i];
      }
      return std::uint64_t(0);
    });
    retained::trim(outward);
    retained::trim(inward);
    retained::trim(outward_exact);
  }

  std::vector<Handle> add_d(std::span<const AabbD> boxes, const AddOptions& o) {
    require_precision("add", true);
    if (o.margin != 0) require_float_margins("add");
    check_boxes_d("add", boxes);
    make_outward(boxes);
    const std::size_t slots = std::size_t(table.slots()) + boxes.size();  // at most, after the add
    if (slot_box_d.size() < slots) {
      slot_box_d.resize(slots);
      slot_exact.resize(slots);
      slot_inner.resize(slots);
    }
    std::vector<Handle> handles = add(outward, o);
    store_d(handles, boxes);
    return handles;
  }

  void move_d(std::span<const Handle> handles, std::span<const AabbD> boxes) {
    require_precision("move", true);
    if (handles.size() != boxes.size())
      throw InvalidInput("BroadPhase::move: " + std::to_string(handles.size()) + " handles but " +
                         std::to_string(boxes.size()) + " boxes");
    check_boxes_d("move", boxes);
    make_outward(boxes);
    move(handles, outward);
    store_d(handles, boxes);
  }

  // Every live object's handle, in slot order.
  std::vector<Handle> live_handles() const {
    std::vector<Handle> h;
    h.reserve(table.live());
    for (std::uint32_t s = 0; s < table.slots(); ++s)
      if (table.kind(s) != HandleTable::kFree) h.push_back(table.handle_of(s));
    return h;
  }

  // shift_origin: every box re-based as a move of every object (the move
  // keeps each cache valid or invalidates it: candidate lists, quiet and fat
  // boxes follow the moved boxes, a static change rebuilds the static tree,
  // the queries' moving tree is refit). The shifted boxes are all checked
  // before anything is applied.
  void shift_origin(const double offset[3]) {
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(offset[k]))
        throw InvalidInput("BroadPhase::shift_origin: offset[" + std::to_string(k) + "] is not finite");
    const std::vector<Handle> handles = live_handles();
    if (handles.empty()) return;
    const auto shifted_defect = [&](std::size_t i, const char* d) {
      throw InvalidInput("BroadPhase::shift_origin: handle " + std::to_string(handles[i]) +
                         ": the shifted box has an " + d + " (outside the finite range)");
    };
    if (options.double_precision) {
      std::vector<AabbD> boxes(handles.size());
      for (std::size_t i = 0; i < handles.size(); ++i) {
        const AabbD& b = slot_box_d[HandleTable::slot_of(handles[i])];
        for (int k = 0; k < 3; ++k) {
          boxes[i].min[k] = b.min[k] - offset[k];
          boxes[i].max[k] = b.max[k] - offset[k];
        }
        if (const char* d = box_defect(boxes[i])) shifted_defect(i, d);
      }
      move_d(handles, boxes);
      return;
    }
    float off[3];
    for (int k = 0; k < 3; ++k) {
      off[k] = static_cast<float>(offset[k]);  // nearest (exact for shift_origin's float offsets)
      if (!std::isfinite(off[k]))
        throw InvalidInput("BroadPhase::shift_origin: offset[" + std::to_string(k) + "] is beyond the float range");
    }
    std::vector<Aabb> boxes(handles.size());
    for (std::size_t i = 0; i < handles.size(); ++i) {
      const Aabb b = box_of(HandleTable::slot_of(handles[i]));
      for (int k = 0; k < 3; ++k) {
        boxes[i].min[k] = b.min[k] - off[k];
        boxes[i].max[k] = b.max[k] - off[k];
      }
      if (const char* d = box_defect(boxes[i])) shifted_defect(i, d);
    }
    move(handles, boxes);
  }

  // Keeps the pairs of `v` whose double boxes overlap (and that the pair
  // filter accepts), in order. `map` (may be null) turns dense moving
  // indices into handles first. Fixed chunks, each compacted in place in
  // parallel, then the chunks' survivors packed together in parallel: the
  // same list for any thread count, and no allocation once the scratch has
  // grown. A pair of two objects whose float boxes are exact is kept
  // without reading any box (the float test was exact); a pair whose
  // inward boxes overlap is kept without reading the double boxes.
  void confirm(std::vector<Pair>& v, const Handle* map) {
    // Live objects whose float box is exact: all of them, and the float
    // test was the double test for every pair (nothing to do unless pairs
    // need mapping or filtering); none, and the flag test is skipped. (One
    // pass over the slots: a fraction of the pass below.)
    std::size_t live_exact = 0;
    for (std::uint32_t s = 0; s < table.slots(); ++s)
      live_exact += (table.kind(s) != HandleTable::kFree) & slot_exact[s];
    if (live_exact == table.live() && !map && !confirm_filter) return;
    const bool some_exact = live_exact != 0;
    constexpr std::size_t kPairs = 16384;
    const std::size_t n = v.size();
    const std::size_t chunks = (n + kPairs - 1) / kPairs;
    confirm_kept.resize(chunks);
    const AabbD* box = slot_box_d.data();
    const Aabb* inner = slot_inner.data();
    const std::uint8_t* exact = slot_exact.data();
    Pair* data = v.data();
    // The second objects' records are scattered (the first ones' come in
    // order): fetched kAhead pairs before they are tested.
    constexpr std::size_t kAhead = 16;
    const auto chunk = [&](std::size_t c) {
      const std::size_t begin = c * kPairs, end = std::min(n, begin + kPairs);
      std::size_t w = begin;
      for (std::size_t i = begin; i < end; ++i) {
        if (i + kAhead < end) {
          const Handle ahead = map ? map[data[i + kAhead].b] : data[i + kAhead].b;
          const Aabb* record = inner + HandleTable::slot_of(ahead);
          __builtin_prefetch(record);
          __builtin_prefetch(reinterpret_cast<const char*>(record) + sizeof(Aabb) - 1);  // a record may cross a line
        }
        Pair p = data[i];
        if (map) p = Pair{map[p.a], map[p.b]};
        const std::uint32_t sa = HandleTable::slot_of(p.a), sb = HandleTable::slot_of(p.b);
        bool keep = (some_exact && (exact[sa] & exact[sb])) || overlaps_branch_free(inner[sa], inner[sb]) ||
                    overlaps(box[sa], box[sb]);
        if (keep && confirm_filter) keep = confirm_filter(p.a, p.b);
        data[w] = p;  // w <= i: the pair at w was read already
        w += keep;
      }
      confirm_kept[c] = w - begin;
    };
    if (chunks == 1) {
      chunk(0);
    } else if (chunks > 1) {
      tbb::parallel_for(std::size_t(0), chunks, chunk);
    }
    std::size_t total = 0;
    bool gaps = false;
    for (std::size_t c = 0; c < chunks; ++c) {
      gaps |= total != c * kPairs;
      total += confirm_kept[c];
    }
    if (!gaps) {  // only the last chunk may have dropped pairs
      v.resize(total);
      return;
    }
    confirm_scratch.resize(total);
    // confirm_kept becomes each chunk's first output position.
    std::size_t at = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      const std::size_t kept = confirm_kept[c];
      confirm_kept[c] = at;
      at += kept;
    }
    tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
      const std::size_t first = confirm_kept[c], last = c + 1 < chunks ? confirm_kept[c + 1] : total;
      std::copy(data + c * kPairs, data + c * kPairs + (last - first), confirm_scratch.data() + first);
    });
    v.swap(confirm_scratch);
    retained::trim(confirm_scratch);
  }

  // The all-moving frame in double-precision mode: the hybrid system's
  // candidates, confirmed, into `next`.
  void all_moving_candidates() {
    moving_pairs.clear();
    static_pairs.clear();
    static_pairs_valid = false;
    next.clear();
    if (moving_handle.size() < 2) return;
    check_max_pairs(hybrid.update(moving_boxes.view()).size());
    hybrid.swap_pairs(next);
    confirm(next, moving_identity ? nullptr : moving_handle.data());
  }

  void query_box_d(const AabbD& q, std::vector<Handle>& out, const QueryFilter* qf = nullptr) {
    if (const char* d = box_defect(q)) throw InvalidInput(std::string("BroadPhase::query_box: ") + d);
    const Aabb f = detail::outward_box(q);
    sync_queries();
    out.clear();
    const auto collect = [&](std::uint32_t, const BoxTree::Item& it) {
      if (overlaps(slot_box_d[HandleTable::slot_of(it.id)], q) && (!qf || passes(*qf, it.id))) out.push_back(it.id);
    };
    static_tree.for_each_overlap(f, collect);
    moving_tree.for_each_overlap(f, collect);
    std::sort(out.begin(), out.end());
  }

  // ---- queries -------------------------------------------------------------

  // Box hits are written straight into `out` (cleared first): a caller that
  // keeps its vector pays no allocation once it is large enough.
  void query_box(const Aabb& q, std::vector<Handle>& out, const QueryFilter* qf = nullptr) {
    if (const char* d = box_defect(q)) throw InvalidInput(std::string("BroadPhase::query_box: ") + d);
    if (options.double_precision) {  // the double box the float box denotes
      query_box_d({{q.min[0], q.min[1], q.min[2]}, {q.max[0], q.max[1], q.max[2]}}, out, qf);
      return;
    }
    sync_queries();
    out.clear();
    const auto collect = [&](std::uint32_t, const BoxTree::Item& it) {
      if (!qf || passes(*qf, it.id)) out.push_back(it.id);
    };
    static_tree.for_each_overlap(q, collect);
    moving_tree.for_each_overlap(q, collect);
    std::sort(out.begin(), out.end());
  }

  // Ray hits are sorted by entry t in a per-thread scratch (no growth
  // reallocations per query), then their handles written into `out`.
  static void check_ray(const char* call, const float origin[3], const float direction[3], float max_t) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(origin[k]))
        throw InvalidInput(std::string("BroadPhase::") + call + ": origin[" + std::to_string(k) + "] is not finite");
      if (!std::isfinite(direction[k]))
        throw InvalidInput(std::string("BroadPhase::") + call + ": direction[" + std::to_string(k) +
                           "] is not finite");
    }
    if (!(max_t >= 0))
      throw InvalidInput(std::string("BroadPhase::") + call + ": max_t must be >= 0 (infinity allowed)");
  }

  // Hits with their entry t, sorted by (t, handle) in a per-thread scratch
  // (no growth reallocations per query), then their handles written into
  // `out`. walk(collect) runs the trees.
  template <class Walk>
  void sorted_by_entry(std::vector<Handle>& out, const QueryFilter* qf, Walk&& walk) const {
    struct Hit {
      float t;
      Handle h;
    };
    thread_local std::vector<Hit> hits;
    hits.clear();
    walk([&](const BoxTree::Item& it, float t) {
      if (!qf || passes(*qf, it.id)) hits.push_back({t, it.id});
    });
    std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.t < b.t || (a.t == b.t && a.h < b.h); });
    out.resize(hits.size());
    for (std::size_t i = 0; i < hits.size(); ++i) out[i] = hits[i].h;
    retained::trim(hits);
  }

  void query_ray(const float origin[3], const float direction[3], float max_t, std::vector<Handle>& out,
                 const QueryFilter* qf = nullptr) {
    check_ray("query_ray", origin, direction, max_t);
    sync_queries();
    const detail::RaySegment ray(origin, direction, max_t);
    sorted_by_entry(out, qf, [&](const auto& collect) {
      static_tree.for_each_ray_hit(ray, collect);
      moving_tree.for_each_ray_hit(ray, collect);
    });
  }

  std::optional<RayHit> raycast_closest(const float origin[3], const float direction[3], float max_t,
                                        const QueryFilter* qf = nullptr) {
    check_ray("raycast_closest", origin, direction, max_t);
    sync_queries();
    const detail::RaySegment ray(origin, direction, max_t);
    float best_t = std::numeric_limits<float>::infinity();
    std::uint32_t best = BoxTree::kNone;  // never a handle (kInvalidHandle)
    if (qf) {
      const auto accept = [&](std::uint32_t h) { return passes(*qf, h); };
      static_tree.closest_ray_hit(ray, best_t, best, accept);
      moving_tree.closest_ray_hit(ray, best_t, best, accept);
    } else {
      static_tree.closest_ray_hit(ray, best_t, best);
      moving_tree.closest_ray_hit(ray, best_t, best);
    }
    if (best == BoxTree::kNone) return std::nullopt;
    return RayHit{best, best_t};
  }

  void query_box_cast(const Aabb& box, const float displacement[3], std::vector<Handle>& out,
                      const QueryFilter* qf = nullptr) {
    if (const char* d = box_defect(box)) throw InvalidInput(std::string("BroadPhase::query_box_cast: box: ") + d);
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(displacement[k]))
        throw InvalidInput("BroadPhase::query_box_cast: displacement[" + std::to_string(k) + "] is not finite");
    sync_queries();
    const detail::BoxCast cast(box, displacement);
    sorted_by_entry(out, qf, [&](const auto& collect) {
      static_tree.for_each_cast_hit(cast, collect);
      moving_tree.for_each_cast_hit(cast, collect);
    });
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

  // Calls f(slot) for each live slot whose filter, user data, margin or
  // sweep differs from the defaults, in slot order.
  template <class F>
  void for_each_attributed(F&& f) const {
    const std::uint32_t n = std::min<std::uint32_t>(table.slots(), static_cast<std::uint32_t>(slot_filter.size()));
    for (std::uint32_t s = 0; s < n; ++s)
      if (table.kind(s) != HandleTable::kFree &&
          (!is_default(slot_filter[s]) || slot_user_data[s] != 0 || slot_margin[s] != 0 || slot_swept[s]))
        f(s);
  }

  // The state as write_snapshot reads it: views of the table and the
  // results, boxes by box_of; only the stats' marks and the attributed
  // objects are collected.
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
    for_each_attributed([&](std::uint32_t s) {
      src.attributes.push_back({.slot = s,
                                .filter = slot_filter[s],
                                .user_data = slot_user_data[s],
                                .margin = slot_margin[s],
                                .swept = slot_swept[s] != 0,
                                .sweep_end = slot_swept[s] ? slot_end[s] : Aabb{}});
    });
    if (options.double_precision) src.box_d = [this](std::uint32_t s) { return slot_box_d[s]; };
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
    for_each_attributed([&](std::uint32_t) { ++shape.attributes; });
    shape.double_precision = options.double_precision;
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
    // The per-slot attributes, defaults but for the objects listed.
    const std::uint32_t slots = table.slots();
    slot_filter.assign(slots, Filter{});
    slot_user_data.assign(slots, 0);
    slot_margin.assign(slots, 0.0f);
    slot_end.assign(slots, Aabb{});
    slot_swept.assign(slots, 0);
    for (const detail::ObjectAttributes& a : st.attributes) {
      slot_filter[a.slot] = a.filter;
      slot_user_data[a.slot] = a.user_data;
      slot_margin[a.slot] = a.margin;
      slot_swept[a.slot] = a.swept;
      slot_end[a.slot] = a.sweep_end;
      filtered_objects += !is_default(a.filter);
      margined_objects += a.margin > 0;
      swept_objects += a.swept;
    }
    // Double precision: the double boxes as given, the float boxes the
    // engine holds rounded from them (as add and move round them).
    if (st.double_precision) {
      slot_box_d = std::move(st.boxes_d);
      slot_exact.assign(slots, 0);
      slot_inner.assign(slots, Aabb{});
      for (std::uint32_t s = 0; s < slots; ++s)
        if (table.kind(s) != HandleTable::kFree)
          slot_exact[s] = detail::round_box(slot_box_d[s], slot_box[s], slot_inner[s]);
    }
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
  impl_->require_precision("add", false);
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
  if (m.options.double_precision) {
    m.slot_box_d.reserve(objects);
    m.slot_exact.reserve(objects);
    m.slot_inner.reserve(objects);
  }
}
void BroadPhase::move(std::span<const Handle> handles, std::span<const Aabb> boxes) {
  impl_->require_precision("move", false);
  impl_->move(handles, boxes);
}
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
  if (state.double_precision != impl_->options.double_precision)
    throw InvalidInput(std::string("BroadPhase::restore: a snapshot of a ") +
                       (state.double_precision ? "double_precision" : "float") + " broad phase into a " +
                       (impl_->options.double_precision ? "double_precision" : "float") + " one");
  auto fresh = std::make_unique<Impl>(impl_->options);
  fresh->filter = impl_->filter;
  fresh->confirm_filter = impl_->confirm_filter;
  fresh->assign(std::move(state));
  impl_ = std::move(fresh);
}
BroadPhase BroadPhase::from_snapshot(std::span<const std::byte> data, const BroadPhaseOptions& options) {
  detail::BroadPhaseState state = detail::read_snapshot(data, "BroadPhase::from_snapshot");
  BroadPhaseOptions o = options;
  o.double_precision = state.double_precision;
  BroadPhase bp(o);
  bp.impl_->assign(std::move(state));
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
  (impl_->options.double_precision ? impl_->confirm_filter : impl_->filter) = std::move(filter);
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
  impl_->require_precision("add", false);
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

std::optional<RayHit> BroadPhase::raycast_closest(const Vec3f& origin, const Vec3f& direction, float max_t) const {
  return impl_->raycast_closest(origin.data(), direction.data(), max_t);
}
std::vector<Handle> BroadPhase::query_box_cast(const Aabb& box, const Vec3f& displacement) const {
  thread_local std::vector<Handle> scratch;
  impl_->query_box_cast(box, displacement.data(), scratch);
  std::vector<Handle> out(scratch.begin(), scratch.end());
  retained::trim(scratch);
  return out;
}
std::size_t BroadPhase::query_box_cast(const Aabb& box, const Vec3f& displacement, std::vector<Handle>& out) const {
  impl_->query_box_cast(box, displacement.data(), out);
  return out.size();
}
std::size_t BroadPhase::query_box_cast(const Aabb& box, const Vec3f& displacement, const HitVisitor& visit) const {
  return visit_hits(visit, [&](std::vector<Handle>& hits) { impl_->query_box_cast(box, displacement.data(), hits); });
}

void BroadPhase::set_margin(std::span<const Handle> handles, float margin) { impl_->set_margin(handles, margin); }
float BroadPhase::margin(Handle h) const { return impl_->slot_margin[HandleTable::slot_of(impl_->checked("margin", h))]; }
void BroadPhase::move_swept(std::span<const Handle> handles, std::span<const Aabb> boxes) {
  impl_->require_float_margins("move_swept");
  impl_->move(handles, boxes, /*swept=*/true);
}

void BroadPhase::set_filter(std::span<const Handle> handles, const Filter& filter) { impl_->set_filter(handles, filter); }
Filter BroadPhase::filter(Handle h) const {
  return impl_->slot_filter[HandleTable::slot_of(impl_->checked("filter", h))];
}
void BroadPhase::set_user_data(std::span<const Handle> handles, std::span<const std::uint64_t> values) {
  impl_->set_user_data(handles, values);
}
std::uint64_t BroadPhase::user_data(Handle h) const {
  return impl_->slot_user_data[HandleTable::slot_of(impl_->checked("user_data", h))];
}
void BroadPhase::pair_user_data(std::span<const Pair> pairs, std::span<std::array<std::uint64_t, 2>> out) const {
  if (pairs.size() != out.size())
    throw InvalidInput("BroadPhase::pair_user_data: " + std::to_string(pairs.size()) + " pairs but room for " +
                       std::to_string(out.size()));
  for (std::size_t i = 0; i < pairs.size(); ++i)
    out[i] = {impl_->user_data_or_zero(pairs[i].a), impl_->user_data_or_zero(pairs[i].b)};
}
void BroadPhase::user_data(std::span<const Handle> handles, std::span<std::uint64_t> out) const {
  if (handles.size() != out.size())
    throw InvalidInput("BroadPhase::user_data: " + std::to_string(handles.size()) + " handles but room for " +
                       std::to_string(out.size()));
  for (std::size_t i = 0; i < handles.size(); ++i) out[i] = impl_->user_data_or_zero(handles[i]);
}

std::vector<Handle> BroadPhase::query_box(const Aabb& box, const QueryFilter& filter) const {
  std::vector<Handle> out;
  impl_->query_box(box, out, &filter);
  return out;
}
std::size_t BroadPhase::query_box(const Aabb& box, std::vector<Handle>& out, const QueryFilter& filter) const {
  impl_->query_box(box, out, &filter);
  return out.size();
}
std::size_t BroadPhase::query_box(const Aabb& box, const HitVisitor& visit, const QueryFilter& filter) const {
  return visit_hits(visit, [&](std::vector<Handle>& hits) { impl_->query_box(box, hits, &filter); });
}
std::vector<Handle> BroadPhase::query_ray(const Vec3f& origin, const Vec3f& direction, float max_t,
                                          const QueryFilter& filter) const {
  std::vector<Handle> out;
  impl_->query_ray(origin.data(), direction.data(), max_t, out, &filter);
  return out;
}
std::size_t BroadPhase::query_ray(const Vec3f& origin, const Vec3f& direction, float max_t, std::vector<Handle>& out,
                                  const QueryFilter& filter) const {
  impl_->query_ray(origin.data(), direction.data(), max_t, out, &filter);
  return out.size();
}
std::size_t BroadPhase::query_ray(const Vec3f& origin, const Vec3f& direction, float max_t, const HitVisitor& visit,
                                  const QueryFilter& filter) const {
  return visit_hits(visit,
                    [&](std::vector<Handle>& hits) { impl_->query_ray(origin.data(), direction.data(), max_t, hits, &filter); });
}
std::optional<RayHit> BroadPhase::raycast_closest(const Vec3f& origin, const Vec3f& direction, float max_t,
                                                  const QueryFilter& filter) const {
  return impl_->raycast_closest(origin.data(), direction.data(), max_t, &filter);
}
std::vector<Handle> BroadPhase::query_box_cast(const Aabb& box, const Vec3f& displacement,
                                               const QueryFilter& filter) const {
  std::vector<Handle> out;
  impl_->query_box_cast(box, displacement.data(), out, &filter);
  return out;
}
std::size_t BroadPhase::query_box_cast(const Aabb& box, const Vec3f& displacement, std::vector<Handle>& out,
                                       const QueryFilter& filter) const {
  impl_->query_box_cast(box, displacement.data(), out, &filter);
  return out.size();
}
std::size_t BroadPhase::query_box_cast(const Aabb& box, const Vec3f& displacement, const HitVisitor& visit,
                                       const QueryFilter& filter) const {
  return visit_hits(visit, [&](std::vector<Handle>& hits) { impl_->query_box_cast(box, displacement.data(), hits, &filter); });
}

std::size_t BroadPhase::size() const { return impl_->table.live(); }
bool BroadPhase::contains(Handle h) const { return impl_->table.live(h); }
Aabb BroadPhase::box(Handle h) const {
  impl_->require_precision("box", false);
  return impl_->box_of(HandleTable::slot_of(impl_->checked("box", h)));
}
bool BroadPhase::is_static(Handle h) const {
  return impl_->table.kind(HandleTable::slot_of(impl_->checked("is_static", h))) == HandleTable::kStatic;
}
std::uint8_t BroadPhase::layer(Handle h) const {
  return impl_->table.layer(HandleTable::slot_of(impl_->checked("layer", h)));
}
const BroadPhaseOptions& BroadPhase::options() const { return impl_->options; }

// ---- large worlds ----------------------------------------------------------

void BroadPhase::shift_origin(const std::array<float, 3>& offset) {
  const double d[3] = {offset[0], offset[1], offset[2]};
  impl_->shift_origin(d);
}
void BroadPhase::shift_origin_d(const std::array<double, 3>& offset) { impl_->shift_origin(offset.data()); }
std::vector<Handle> BroadPhase::add(std::span<const AabbD> boxes, const AddOptions& options) {
  return impl_->add_d(boxes, options);
}
void BroadPhase::move(std::span<const Handle> handles, std::span<const AabbD> boxes) { impl_->move_d(handles, boxes); }
AabbD BroadPhase::box_d(Handle h) const {
  impl_->require_precision("box_d", true);
  return impl_->slot_box_d[HandleTable::slot_of(impl_->checked("box_d", h))];
}
void BroadPhase::query_box_d(const AabbD& box, std::vector<Handle>& out, const QueryFilter* filter) const {
  impl_->require_precision("query_box", true);
  impl_->query_box_d(box, out, filter);
}

}  // namespace hbp
