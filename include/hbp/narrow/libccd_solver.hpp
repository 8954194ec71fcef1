// SPDX-License-Identifier: MIT
#pragma once
// Adapter to libccd (Debian libccd-dev 2.1, double precision): the same
// shapes through libccd's GJK, MPR and EPA, for comparison and as an
// alternative solver. libccd's EPA allocates its polytope on the heap per
// query; its MPR does not.
#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/hit.hpp"

namespace hbp::narrow {

enum class CcdAlgorithm {
  Mpr,     // ccdMPRIntersect / ccdMPRPenetration
  GjkEpa,  // ccdGJKIntersect / ccdGJKPenetration
};

// False when the library was built without libccd.
bool libccd_available();

// Throws hbp::Error if libccd is unavailable.
bool libccd_intersect(const Convex& a, const Convex& b, Hit* hit, CcdAlgorithm algorithm);

}  // namespace hbp::narrow
