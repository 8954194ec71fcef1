// SPDX-License-Identifier: MIT
#pragma once
// The narrow phase of the hybrid system: exact shape tests on the candidate
// pairs the broad phase reports, one Contact per colliding pair.
//
//   hbp::NarrowPhase narrow;                     // closed forms + GJK/EPA
//   std::vector<hbp::Contact> contacts;
//   bp.update(boxes, [&](std::uint32_t, const hbp::Pair* p, std::size_t n) {
//     narrow.process(scenario.shapes(), p, n, contacts);
//   });
#include <cstddef>
#include <cstdint>
#include <vector>

#include "hbp/narrow/contact.hpp"
#include "hbp/narrow/intersect.hpp"
#include "hbp/narrow/narrow_cache.hpp"
#include "hbp/pair.hpp"
#include "hbp/shape.hpp"

namespace hbp {

struct NarrowOptions {
  NarrowMethod method = NarrowMethod::Auto;
  // False: intersection only (faster; contacts carry ids, depth 0, zero normal).
  bool contacts = true;
  // Relative tolerance of a contact's depth from GJK + EPA (methods Auto and
  // GjkEpa; closed forms are exact, libccd keeps its own): the reported
  // depth is at most this much above the true minimum translation, never
  // below it. The default is inside the agreement band with Bullet; 1e-4 or
  // finer costs about 2.4 more EPA iterations a decade (docs/narrow-phase.md).
  // InvalidInput outside [kMinDepthTolerance, kMaxDepthTolerance].
  double depth_tolerance = narrow::kContactDepthTolerance;
};

class NarrowPhase {
 public:
  // InvalidInput if an option is out of range.
  explicit NarrowPhase(const NarrowOptions& options = {});

  // Tests pairs[0..count) (ids index `shapes`) and appends a Contact for each
  // colliding pair, in pair order. Returns how many were appended. Const and
  // thread-safe: threads may share one NarrowPhase with separate outputs. No
  // allocation besides the growth of `out`. InvalidInput if an id is out of
  // range.
  std::size_t process(const std::vector<Shape>& shapes, const Pair* pairs, std::size_t count,
                      std::vector<Contact>& out) const;
  // The same with frame-to-frame coherence: `cache` (read only, may be
  // shared by threads) holds the last frame's directions; what this call
  // learns is appended to `learned`, to be committed to the cache after the
  // frame (NarrowCache::commit). Same verdicts as without a cache.
  std::size_t process(const std::vector<Shape>& shapes, const Pair* pairs, std::size_t count,
                      std::vector<Contact>& out, const NarrowCache* cache,
                      std::vector<NarrowCacheEntry>* learned) const;

  const NarrowOptions& options() const { return options_; }

 private:
  NarrowOptions options_;
};

}  // namespace hbp
