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
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "hbp/pair.hpp"

namespace hbp {

struct NarrowCacheEntry {
  Pair pair;
  float dir[3];            // unit, from a towards b
  std::uint16_t contact;   // 1: dir is a contact normal (the pair collided), 0: a separating axis
  std::uint16_t has_tetra; // 1: tetra holds the tetrahedron that enclosed the origin (a colliding pair)
  // The four support directions of that tetrahedron, octahedron-coded
  // (oct_encode): next frame they are queried again and, if the new points
  // still enclose the origin, EPA starts from them without GJK.
  std::int16_t tetra[4][2];
};
static_assert(sizeof(NarrowCacheEntry) == 40,
              "NarrowCacheEntry is packed: 2 ids + 3 floats + 2 flags + 4 directions of 2 x 16 bits");

// A direction in 2 x 16 bits: projected on the octahedron |x|+|y|+|z| = 1,
// its lower half folded over the upper, x and y kept (about 5e-5 rad).
// Any code decodes to a non-zero direction (not unit).
inline void oct_encode(double x, double y, double z, std::int16_t out[2]) {
  const double s = std::fabs(x) + std::fabs(y) + std::fabs(z);
  const double inv = s > 0 ? 1 / s : 0;
  double u = x * inv, v = y * inv;
  if (z < 0) {
    const double fu = (1 - std::fabs(v)) * (u >= 0 ? 1 : -1);
    const double fv = (1 - std::fabs(u)) * (v >= 0 ? 1 : -1);
    u = fu;
    v = fv;
  }
  // Rounded to nearest (|u|, |v| <= 1: no overflow).
  out[0] = static_cast<std::int16_t>(u * 32767.0 + (u >= 0 ? 0.5 : -0.5));
  out[1] = static_cast<std::int16_t>(v * 32767.0 + (v >= 0 ? 0.5 : -0.5));
}
inline void oct_decode(const std::int16_t in[2], double out[3]) {
  double u = in[0] * (1.0 / 32767.0), v = in[1] * (1.0 / 32767.0);
  const double z = 1 - std::fabs(u) - std::fabs(v);
  if (z < 0) {
    const double fu = (1 - std::fabs(v)) * (u >= 0 ? 1 : -1);
    const double fv = (1 - std::fabs(u)) * (v >= 0 ? 1 : -1);
    u = fu;
    v = fv;
  }
  out[0] = u;
  out[1] = v;
  out[2] = z;
}

class NarrowCache {
 public:
  // The previous frame's entry for the pair, or null.
  const NarrowCacheEntry* entry(Pair p) const {
    if (p.a + 1 >= row_.size()) return nullptr;
    for (std::uint32_t k = row_[p.a]; k < row_[p.a + 1]; ++k)
      if (entries_[k].pair.b == p.b) return &entries_[k];
    return nullptr;
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
  // ids. Linear in pairs + objects.
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
