// SPDX-License-Identifier: MIT
#pragma once
// Frame-to-frame coherence of the narrow phase: for each candidate pair, the
// direction the last frame learned (the separating axis of a pair found
// apart, the contact normal of a colliding pair; unit, from a towards b).
// Next frame, one support query along it usually proves the pair still
// apart; otherwise GJK starts its search from it.
//
// Flat arrays keyed by the pair: entries grouped by the pair's first object
// (row offsets per object, a CSR), so a lookup scans the few pairs of one
// object. The frame's lookups only read it (threads share it); what a frame
// learns is appended to per-thread (or per-cell) vectors and committed after
// the frame. Memory: the frame's pairs and one offset per object.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "hbp/pair.hpp"

namespace hbp {

struct NarrowCacheEntry {
  Pair pair;
  float dir[3];           // unit, from a towards b
  std::uint32_t contact;  // 1: dir is a contact normal (the pair collided), 0: a separating axis
};
// Every candidate pair reads one entry per frame, on a random row: kept to
// 24 bytes (a colliding pair's next start is rebuilt from dir alone).
static_assert(sizeof(NarrowCacheEntry) == 24, "NarrowCacheEntry is packed: 2 ids + 3 floats + a flag");

class NarrowCache {
 public:
  // The previous frame's entry for the pair, or null.
  const NarrowCacheEntry* entry(Pair p) const {
    if (p.a + 1 >= row_.size()) return nullptr;
    for (std::uint32_t k = row_[p.a]; k < row_[p.a + 1]; ++k)
      if (entries_[k].pair.b == p.b) return &entries_[k];
    return nullptr;
  }
  // Starts loading the row offset of first object `a`: a few pairs before
  // prefetch(a), which reads it (a demand miss there would stall the pair
  // being computed).
  void prefetch_row(std::uint32_t a) const {
    if (a < row_.size()) __builtin_prefetch(row_.data() + a);
  }
  // Starts loading the row of first object `a` (the pairs of a cell come in
  // no useful order: without this every lookup waits for memory).
  void prefetch(std::uint32_t a) const {
    if (a + 1 < row_.size()) {
      const std::uint32_t k = row_[a];
      if (k < entries_.size()) __builtin_prefetch(entries_.data() + k);
    }
  }
  // The previous frame's direction for the pair, or null.
  const float* find(Pair p) const {
    const NarrowCacheEntry* e = entry(p);
    return e ? e->dir : nullptr;
  }
  // Replaces the cache with what this frame learned: `lists[0..count)`, in
  // any order (pairs absent from them are forgotten). `objects` bounds the
  // ids: an entry beyond them throws InvalidInput and leaves the cache as it
  // was. Linear in pairs + objects.
  void commit(const std::vector<NarrowCacheEntry>* lists, std::size_t count, std::size_t objects);
  // The same from scattered lists (e.g. one per cell of the pipeline).
  void commit(const std::vector<const std::vector<NarrowCacheEntry>*>& lists, std::size_t objects);
  void clear();
  std::size_t size() const { return entries_.size(); }

 private:
  template <class List>
  void commit_lists(const List& list_at, std::size_t count, std::size_t objects);
  std::vector<std::uint32_t> row_;  // objects + 1 offsets into entries_
  std::vector<NarrowCacheEntry> entries_;
};

}  // namespace hbp
