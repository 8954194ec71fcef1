// SPDX-License-Identifier: MIT
#pragma once
// De-duplication: the ownership rule, the one place it is written.
//
// An object straddling a split plane is in every cell it overlaps, so a pair
// of such objects is found in several cells. Each cell keeps only the pairs
// it OWNS: those whose ownership point
//
//     p = max(min_a, min_b)   (per axis: the minimum corner of the boxes'
//                              intersection)
//
// lies in the cell's half-open region [lo, hi) (CellRegion::contains). p lies
// in both boxes, so the cell holding p received both objects (routing uses
// the same half-open rule); the regions tile space, so exactly one cell holds
// p. Every overlapping pair is reported once, with no global set and no sort.
//
// Callers: filter_owned (owned_pairs.hpp: CellEngine::find_owned_pairs for
// brute force and the hardware models' simulation), the distributed broad
// phase's rank filter (sides/owns_sides below), the scalar kernel, and
// the SIMD kernels (engines/box_kernels_*.cpp), which test the rule on the
// candidate lanes they already hold with the vector form beside this file
// (ownership_lanes.hpp, one template; ownership_avx2.hpp and
// ownership_avx512.hpp give it each ISA's compares): the same point, the
// same comparisons, a lane at a time.
//
// Plain inline C on floats (no std templates): kernels compiled for other
// instruction sets sit next to its callers (see engines/box_kernels.hpp).
// The point and the two tests below are constexpr and host/device
// (HBP_HOST_DEVICE): the CUDA kernels (src/cuda) call these very functions.
#include "hbp/cell_region.hpp"
#include "hbp/host_device.hpp"

namespace hbp::dedup {

// The ownership point's coordinate on one axis: the larger of the two minima.
HBP_HOST_DEVICE constexpr float ownership_coord(float min_a, float min_b) { return min_a > min_b ? min_a : min_b; }

// True when the cell of region r reports the pair of boxes whose minimum
// corners are (ax, ay, az) and (bx, by, bz) (the boxes are known to overlap).
HBP_HOST_DEVICE constexpr bool owns(const CellRegion& r, float ax, float ay, float az, float bx, float by, float bz) {
  return r.contains(ownership_coord(ax, bx), ownership_coord(ay, by), ownership_coord(az, bz));
}

// The same when box b follows box a in min-x order (the sweep): b's min x is
// already the larger, so p's x is b's.
HBP_HOST_DEVICE constexpr bool owns_sorted_x(const CellRegion& r, float ay, float az, float bx, float by, float bz) {
  return r.contains(bx, ownership_coord(by, ay), ownership_coord(bz, az));
}

// The same rule taken apart per object, for many pairs against one region
// (a rank's domain, distributed_broadphase.cpp): on each axis max(a, b) >= lo
// iff a >= lo or b >= lo, and max(a, b) < hi iff a < hi and b < hi. So one
// byte per object, sides(), decides every pair: owns_sides(). Bits 0-2: min
// >= lo on x, y, z; bits 3-5: min < hi. (Written out per axis: GCC 12.2 at
// -O1 -fsanitize=undefined miscompiled the loop form `bits |= (m >= lo[k] ?
// 1u : 0u) << k`, every bit set; the MPI tests caught it as pairs reported
// twice.)
inline unsigned char sides(const CellRegion& r, float x, float y, float z) {
  const unsigned ge = unsigned{x >= r.lo[0]} | unsigned{y >= r.lo[1]} * 2u | unsigned{z >= r.lo[2]} * 4u;
  const unsigned lt = unsigned{x < r.hi[0]} | unsigned{y < r.hi[1]} * 2u | unsigned{z < r.hi[2]} * 4u;
  return static_cast<unsigned char>(ge | lt * 8u);
}

inline bool owns_sides(unsigned a, unsigned b) { return ((a | b) & 7u) == 7u && (a & b & 56u) == 56u; }

// The same test as one AND, for the AVX-512 kernels (one vptestnmd per row and
// vector of candidates instead of two maxima and six compares): a box's
// owner code is its sides() complemented (the conditions it fails; bits 6-31
// always set), a row's demand the conditions its candidates must not fail:
// the >= lo sides the row itself fails, every < hi side, and bit 8 (failed
// by every box) when the row fails a < hi side itself, so it owns nothing.
// owns_sides(a, b) == ((owner_code(b) & owner_demand(a)) == 0). (In an
// anonymous namespace: the AVX-512 kernels' file calls them, and its copy
// must not be the one the linker keeps for callers without AVX-512.)
namespace {
inline unsigned owner_code(unsigned sides_byte) { return ~sides_byte; }
inline unsigned owner_demand(unsigned sides_byte) {
  return ((sides_byte & 7u) ^ 7u) | 56u | ((sides_byte & 56u) == 56u ? 0u : 256u);
}
}  // namespace

}  // namespace hbp::dedup
