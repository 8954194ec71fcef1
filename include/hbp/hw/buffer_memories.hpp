// SPDX-License-Identifier: MIT
#pragma once
// The buffer's 6m dual-port memories: one per (coordinate, memory group),
// `depth` 32-bit words each. Coordinates are ordered min x, max x, min y,
// max y, min z, max z as in the paper. The models issue at most two accesses
// (ports A and B) per memory per cycle by construction of their sequencers.
#include <cstdint>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/hw/float_comparator.hpp"

namespace hbp::hw {

inline constexpr int kCoordinates = 6;
// Memory coordinate index of min/max along axis.
constexpr int min_coordinate(int axis) { return 2 * axis; }
constexpr int max_coordinate(int axis) { return 2 * axis + 1; }

// The six words of one AABB as they sit in a memory group.
struct AabbWords {
  std::uint32_t word[kCoordinates];
};

// Most AABB slots (groups x depth) a simulated buffer allocates: 2^24 slots
// are 384 MiB of words, far past the paper's designs (16 x 1024). Larger
// configurations still work analytically (cycles, resources); simulating
// them is refused with InvalidInput instead of std::bad_alloc.
inline constexpr std::uint64_t kMaxSimulatedSlots = std::uint64_t{1} << 24;

class BufferMemories {
 public:
  // Throws InvalidInput when groups x depth > kMaxSimulatedSlots.
  void configure(std::uint32_t groups, std::uint32_t depth);
  std::uint32_t groups() const { return groups_; }
  std::uint32_t depth() const { return depth_; }

  // Writes the six words of `box` at `address` of every memory of `group`.
  void write_group(std::uint32_t group, std::uint32_t address, const Aabb& box);
  // The six words at `address` of the memories of `group`; address < depth.
  AabbWords read_group(std::uint32_t group, std::uint32_t address) const {
    AabbWords w;
    for (int c = 0; c < kCoordinates; ++c) w.word[c] = words_[index(c, group, address)];
    return w;
  }
  std::uint32_t word(int coordinate, std::uint32_t group, std::uint32_t address) const {
    return words_[index(coordinate, group, address)];
  }

 private:
  std::size_t index(int coordinate, std::uint32_t group, std::uint32_t address) const {
    return (static_cast<std::size_t>(coordinate) * groups_ + group) * depth_ + address;
  }
  std::uint32_t groups_ = 0;
  std::uint32_t depth_ = 0;
  std::vector<std::uint32_t> words_;
};

// The six-comparator, one-AND test of one candidate pair as the compare stage
// wires it: anchor.max >= partner.min and anchor.min <= partner.max per axis.
inline bool compare_stage_overlap(const AabbWords& anchor, const AabbWords& partner) {
  bool all = true;
  for (int axis = 0; axis < 3; ++axis) {
    const int lo = min_coordinate(axis), hi = max_coordinate(axis);
    all &= f32_greater_equal(anchor.word[hi], partner.word[lo]);
    all &= f32_less_equal(anchor.word[lo], partner.word[hi]);
  }
  return all;
}

}  // namespace hbp::hw
