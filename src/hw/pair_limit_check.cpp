// SPDX-License-Identifier: MIT
#include "hbp/hw/pair_limit_check.hpp"

#include <string>

#include "hbp/error.hpp"

namespace hbp::hw {

void check_pair_limit(std::size_t appended, std::uint64_t max_pairs, std::uint32_t n) {
  if (appended > max_pairs)
    throw CapacityExceeded("cell of " + std::to_string(n) + " boxes has more than " + std::to_string(max_pairs) +
                           " overlapping pairs (max_pairs)");
}

}  // namespace hbp::hw
