// SPDX-License-Identifier: MIT
#pragma once
// Result of one exact shape test before it is stored as an hbp::Contact.
#include "hbp/narrow/vec_math.hpp"

namespace hbp::narrow {

struct Hit {
  V3 normal;         // unit, from the first shape towards the second
  double depth = 0;  // penetration depth, >= 0
  V3 point;          // midway between the deepest points of the two shapes
};

}  // namespace hbp::narrow
