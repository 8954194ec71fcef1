// SPDX-License-Identifier: MIT
#include "hbp/hw/buffer_memories.hpp"

#include <string>

#include "hbp/error.hpp"
#include "hbp/hw/float_comparator.hpp"

namespace hbp::hw {

void BufferMemories::configure(std::uint32_t groups, std::uint32_t depth) {
  if (groups == groups_ && depth == depth_) return;
  const std::uint64_t slots = std::uint64_t{groups} * depth;
  if (slots > kMaxSimulatedSlots)
    throw InvalidInput("hardware model: a buffer of m = " + std::to_string(groups) + " groups x depth " +
                       std::to_string(depth) + " = " + std::to_string(slots) + " AABB slots is more than the " +
                       std::to_string(kMaxSimulatedSlots) + " the cycle-by-cycle simulation holds (24 bytes each)");
  groups_ = groups;
  depth_ = depth;
  words_.assign(static_cast<std::size_t>(kCoordinates) * groups * depth, 0u);
}

void BufferMemories::write_group(std::uint32_t group, std::uint32_t address, const Aabb& box) {
  for (int axis = 0; axis < 3; ++axis) {
    words_[index(min_coordinate(axis), group, address)] = f32_bits(box.min[axis]);
    words_[index(max_coordinate(axis), group, address)] = f32_bits(box.max[axis]);
  }
}

}  // namespace hbp::hw
