// SPDX-License-Identifier: MIT
#pragma once
// Exact intersection test of two of the paper's shapes (sphere = ellipsoid,
// cuboid, cylinder, cone) in any orientation, with contact normal,
// penetration depth and contact point.
//
//   hbp::Contact c;
//   if (hbp::intersect(shape_a, shape_b, &c)) use(c.normal, c.depth, c.point);
//
// Thread-safe; no allocation (except with the libccd GJK/EPA method).
#include <cstdint>

#include "hbp/narrow/contact.hpp"
#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/gjk.hpp"
#include "hbp/narrow/hit.hpp"
#include "hbp/shape.hpp"

namespace hbp {

enum class NarrowMethod : std::uint8_t {
  Auto,          // closed forms where they apply (true sphere-sphere,
                 // cuboid-true sphere, cuboid-cuboid), else GJK + EPA
                 // (a pair with an ellipsoid: on its rounded cores)
  GjkEpa,        // our GJK + EPA for every pair (fixed-size buffers)
  LibccdMpr,     // libccd MPR (boolean and penetration; depth along the
                 // centre line, not the minimum translation)
  LibccdGjkEpa,  // libccd GJK + EPA (allocates per query)
};
const char* narrow_method_name(NarrowMethod method);

// True if the shapes intersect (touching counts). With contact non-null, also
// fills normal (a -> b), depth and point; ids are left as they were.
bool intersect(const Shape& a, const Shape& b, Contact* contact = nullptr,
               NarrowMethod method = NarrowMethod::Auto);

// Distance between the shapes if separated (> 0), minus the penetration depth
// if they intersect (<= 0). GJK + EPA, relative accuracy about 1e-7.
double signed_distance(const Shape& a, const Shape& b);

namespace narrow {
// Contacts from GJK + EPA stop when the depth is bracketed within this
// relative tolerance, and report the upper end (a translation that
// separates, never one that falls short). The default keeps every depth
// inside the agreement band with Bullet (1e-3 relative + 5e-4 m,
// docs/narrow-phase.md: the same five uncertified differences as at 1e-4
// on 100,000 pairs) for 17 % fewer EPA iterations than 1e-4; a caller that
// needs finer depths sets NarrowOptions::depth_tolerance.
// signed_distance() keeps EPA's 1e-6.
inline constexpr double kContactDepthTolerance = 1e-3;
// The range NarrowOptions::depth_tolerance accepts.
inline constexpr double kMinDepthTolerance = 1e-9;
inline constexpr double kMaxDepthTolerance = 0.1;

// The same on prepared shapes (what NarrowPhase calls).
bool intersect(const Convex& a, const Convex& b, Hit* hit, NarrowMethod method);
// What a frame learns about a pair, for the next frame: a separating axis,
// or (contact) the contact normal; unit, a -> b. Zero: nothing learned.
struct Coherence {
  V3 dir;
  bool contact = false;
};
// With frame-to-frame coherence: `warm` (may be null) is what the last frame
// learned for this pair; *learned receives this frame's. The verdict never
// depends on `warm`: a cached axis is used only where one support query
// proves separation; a pair that collided last frame skips the quick
// rejects (they would rarely reject it); with contacts, it queries a
// tetrahedron around last frame's contact normal and, if the support points
// enclose the origin (GJK's own test, sliver rule included), EPA starts
// from it without GJK; otherwise GJK goes on from that tetrahedron.
// `depth_tolerance`: EPA's relative tolerance on the depth (contacts only).
bool intersect(const Convex& a, const Convex& b, Hit* hit, NarrowMethod method, const Coherence* warm,
               Coherence* learned, double depth_tolerance = kContactDepthTolerance);
// The warm start of a pair that collided last frame (n: last frame's unit
// contact normal): support points along three directions tilted from n by
// 0.25 rad, 120 degrees apart, and one away from their centroid. Where they
// enclose the origin (tetrahedron_encloses_origin) EPA starts from them.
Simplex cone_tetrahedron(const Convex& a, const Convex& b, const V3& n);
}  // namespace narrow

}  // namespace hbp
