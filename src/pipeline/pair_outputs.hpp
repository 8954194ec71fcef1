// SPDX-License-Identifier: MIT
#pragma once
// The places one cell's pairs can be written to, behind one set of calls
// (extend, truncate, fits, drain_stage): a growing list (std::vector<Pair>),
// a worker's store (RawBuffer<Pair>), and the front of the last frame's list
// that a lane overwrites in place (ListFront, bounded by the room the lanes
// share). The cell writers (cell_pairs.hpp, tiled_cells.hpp) are templates
// over them.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <vector>

#include "hbp/pair.hpp"
#include "partition/raw_buffer.hpp"
#include "pipeline/cell_worker.hpp"
#include "support/huge_pages.hpp"

namespace hbp::detail {

// Fresh output lists of at least this many bytes are faulted in by all
// workers at once (see prefault_pages).
inline constexpr std::size_t kPrefaultBytes = std::size_t{8} << 20;

// The frame's list is a std::vector (the public type of pairs()), from
// malloc. A capacity of whole 2 MiB pages: glibc maps the block on its own as
// that plus its header's 4 KiB page, and Linux places a new mapping top-down
// with its end at the start of a mapping above or of a gap, which for our
// large buffers (whole 2 MiB pages, 2 MiB-aligned) is a 2 MiB boundary; the
// list then starts 4 KiB - 16 bytes below a boundary, and every 2 MiB past it
// can be a huge page (at an arbitrary size the list's first partial 2 MiB
// would be pages of 4 KiB, each a fault costing microseconds). Where the
// guess is wrong, only the capacity differs. Lists under kPrefaultBytes keep
// their size (rounded up, a small list's capacity would pass twice its size,
// and retained::release would free and map it again every frame).
inline std::size_t list_capacity(std::size_t want) {
  static_assert(kHugePageBytes % sizeof(Pair) == 0);
  if (want * sizeof(Pair) < kPrefaultBytes) return want;
  return whole_huge_pages(want * sizeof(Pair)) / sizeof(Pair);
}

// Room in the last frame's list for the lanes writing in place: pairs not
// yet taken by the front lane (growing up from the list's start) or the back
// lane (growing down from its end). One counter for both, so the two blocks
// never overlap whatever order the lanes take their room in.
struct ListRoom {
  std::atomic<std::size_t> free;
  bool take(std::size_t count) {
    std::size_t r = free.load(std::memory_order_relaxed);
    while (r >= count)
      if (free.compare_exchange_weak(r, r - count, std::memory_order_relaxed)) return true;
    return false;
  }
  void give_back(std::size_t count) { free.fetch_add(count, std::memory_order_relaxed); }
};

// The front of the last frame's list, which the front lane overwrites with
// this frame's first cells (never grows past its room).
struct ListFront {
  Pair* base;
  std::size_t used;
  ListRoom* room;
  std::size_t size() const { return used; }
};

// The back of the last frame's list, which the back lane overwrites with
// this frame's last cells, the last cell's pairs ending at `end`, the cell
// before it ending where those start, and so on; the merge moves the block
// to end where the frame's list ends.
struct ListBack {
  Pair* end;
  std::size_t used;  // the block is [end - used, end)
  ListRoom* room;
};

// Grows v's capacity to at least `want`, keeping its pairs: at least
// twofold, and a large list asks for transparent huge pages before the copy
// touches it (a dense frame's list is hundreds of megabytes of fresh pages).
inline void grow_pairs(std::vector<Pair>& v, std::size_t want) {
  if (want <= v.capacity()) return;
  std::vector<Pair> grown;
  grown.reserve(std::max(want, 2 * v.capacity()));
  advise_huge_pages(grown.data(), grown.capacity() * sizeof(Pair));
  grown.insert(grown.end(), v.begin(), v.end());
  v.swap(grown);
}

// Room for `count` more pairs at the end of out (uninitialised in a
// RawBuffer); returns where they go.
inline Pair* extend(std::vector<Pair>& out, std::size_t count) {
  const std::size_t base = out.size();
  grow_pairs(out, base + count);
  out.resize(base + count);
  return out.data() + base;
}
inline Pair* extend(RawBuffer<Pair>& out, std::size_t count) {
  const std::size_t base = out.size();
  out.grow(base + count);  // at least twofold when it reallocates
  return out.data() + base;
}
inline Pair* extend(ListFront& out, std::size_t count) {
  out.used += count;
  return out.base + out.used - count;
}
template <class Out>
void append(Out& out, Pair p) {
  *extend(out, 1) = p;
}

inline void truncate(std::vector<Pair>& out, std::size_t n) { out.resize(n); }
inline void truncate(ListFront& out, std::size_t n) {
  out.room->give_back(out.used - n);
  out.used = n;
}
inline void truncate(RawBuffer<Pair>& out, std::size_t n) { out.truncate(n); }

// Whether count more pairs fit in out below limit (the list's front: in
// the room the back lane left, which they then take).
template <class Out>
bool fits(Out& out, std::size_t count, std::size_t limit) {
  return out.size() + count <= limit;
}
inline bool fits(ListFront& out, std::size_t count, std::size_t) { return out.room->take(count); }

// Appends the stage's first `count` hits to out as canonical pairs.
template <class Out>
void drain_stage(const Worker& w, std::size_t count, Out& out) {
  CellHitStream::write_pairs(w.first.data(), w.second.data(), count, extend(out, count));
}

}  // namespace hbp::detail
