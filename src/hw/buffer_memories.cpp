#include "hbp/hw/buffer_memories.hpp"

#include "hbp/hw/float_comparator.hpp"

namespace hbp::hw {

void BufferMemories::configure(std::uint32_t groups, std::uint32_t depth) {
  if (groups == groups_ && depth == depth_) return;
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
