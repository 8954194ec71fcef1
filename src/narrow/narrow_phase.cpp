// SPDX-License-Identifier: MIT
#include "hbp/narrow/narrow_phase.hpp"

#include <cstdint>
#include <cstdio>
#include <string>

#include "hbp/error.hpp"

namespace hbp {

NarrowPhase::NarrowPhase(const NarrowOptions& options) : options_(options) {
  const double t = options.depth_tolerance;
  // Written so that NaN fails too.
  if (!(t >= narrow::kMinDepthTolerance && t <= narrow::kMaxDepthTolerance)) {
    char message[160];
    std::snprintf(message, sizeof message, "narrow phase: depth_tolerance %g is outside [%g, %g]", t,
                  narrow::kMinDepthTolerance, narrow::kMaxDepthTolerance);
    throw InvalidInput(message);
  }
}

std::size_t NarrowPhase::process(const std::vector<Shape>& shapes, const Pair* pairs, std::size_t count,
                                 std::vector<Contact>& out) const {
  return process(shapes, pairs, count, out, nullptr, nullptr);
}

std::size_t NarrowPhase::process(const std::vector<Shape>& shapes, const Pair* pairs, std::size_t count,
                                 std::vector<Contact>& out, const NarrowCache* cache,
                                 std::vector<NarrowCacheEntry>* learned) const {
  const std::size_t before = out.size();
  const std::size_t n = shapes.size();
  narrow::Convex a;
  std::uint32_t prepared_id = UINT32_MAX;
  // Memory look-ahead: candidate pairs name objects all over the shape
  // array and the cache (sorted or not), so the shapes and cache rows of a
  // pair a few places ahead are requested while this one is computed.
  // The cache row's offset is requested twice as far ahead: prefetch()
  // reads it to find the row.
  constexpr std::size_t kAhead = 8, kRowAhead = 2 * kAhead;
  for (std::size_t k = 0; k < count; ++k) {
    if (cache && k + kRowAhead < count) cache->prefetch_row(pairs[k + kRowAhead].a);
    if (k + kAhead < count) {
      const Pair q = pairs[k + kAhead];
      if (q.a < n && q.b < n) {
        // A Shape spans two cache lines.
        __builtin_prefetch(&shapes[q.a]);
        __builtin_prefetch(reinterpret_cast<const char*>(&shapes[q.a]) + sizeof(Shape) - 1);
        __builtin_prefetch(&shapes[q.b]);
        __builtin_prefetch(reinterpret_cast<const char*>(&shapes[q.b]) + sizeof(Shape) - 1);
        if (cache) cache->prefetch(q.a);
      }
    }
    const Pair p = pairs[k];
    if (p.a >= n || p.b >= n) {
      throw InvalidInput("narrow phase: pair " + std::to_string(p.a) + "-" + std::to_string(p.b) +
                         " names an object beyond the " + std::to_string(n) + " shapes");
    }
    // Bounding spheres apart: nothing to prepare (most broad-phase false
    // positives end here).
    const Shape& sa = shapes[p.a];
    const Shape& sb = shapes[p.b];
    const double ra = narrow::bounding_radius(sa), rb = narrow::bounding_radius(sb);
    const double reach = ra + rb;
    const double dx = sb.position.x - sa.position.x, dy = sb.position.y - sa.position.y,
                 dz = sb.position.z - sa.position.z;
    if (dx * dx + dy * dy + dz * dz > reach * reach) continue;
    // Pairs come sorted or grouped by their first object: its prepared
    // shape is reused across the group.
    if (p.a != prepared_id) {
      a = narrow::make_convex(sa, ra);
      prepared_id = p.a;
    }
    const narrow::Convex b = narrow::make_convex(sb, rb);
    narrow::Hit hit;
    narrow::Coherence warm, now;
    const NarrowCacheEntry* cached = cache ? cache->entry(p) : nullptr;
    if (cached) {
      warm.dir = {cached->dir[0], cached->dir[1], cached->dir[2]};
      warm.contact = cached->contact != 0;
    }
    const bool collide = narrow::intersect(a, b, options_.contacts ? &hit : nullptr, options_.method,
                                           cached ? &warm : nullptr, learned ? &now : nullptr, options_.depth_tolerance);
    if (learned && narrow::norm2(now.dir) > 0) {
      NarrowCacheEntry e{};
      e.pair = p;
      e.dir[0] = static_cast<float>(now.dir.x);
      e.dir[1] = static_cast<float>(now.dir.y);
      e.dir[2] = static_cast<float>(now.dir.z);
      e.contact = now.contact ? 1 : 0;
      learned->push_back(e);
    }
    if (!collide) continue;
    Contact c;
    c.a = p.a;
    c.b = p.b;
    if (options_.contacts) {
      c.normal = narrow::to_vec3(hit.normal);
      c.depth = hit.depth;
      c.point = narrow::to_vec3(hit.point);
    }
    out.push_back(c);
  }
  return out.size() - before;
}

}  // namespace hbp
