// SPDX-License-Identifier: MIT
#pragma once
// Quick reject before GJK: the shapes' oriented bounding boxes (each shape's
// local box of half extents h: exact for a cuboid, enclosing for the curved
// ones) tested on the 15 separating axes. Disjoint boxes prove the shapes
// apart.
#include "hbp/narrow/convex.hpp"

namespace hbp::narrow {

// True if the two oriented boxes are disjoint; *axis (if non-null) is then a
// unit separating axis pointing from a towards b.
bool obb_disjoint(const Convex& a, const Convex& b, V3* axis);

}  // namespace hbp::narrow
