// SPDX-License-Identifier: MIT
#pragma once
// The limits a caller can reach, in one place: each constant, its unit and
// why it is what it is. Inputs past a limit are refused with InvalidInput
// (CapacityExceeded for a frame's pair count) where they enter, never
// truncated or wrapped.
#include <cstdint>

namespace hbp {

// Worker threads of one broad phase (BroadPhaseOptions::threads; 0 = all
// cores). A task arena is sized by it; past a few thousand oneTBB's arena
// slots are not meant to go (above 65,536 the arena's teardown crashes), and
// no machine we target has more than 1,024 hardware threads.
inline constexpr unsigned kMaxThreads = 1024;

// Objects of one frame of the hybrid system (HybridBroadPhase, KdPartition):
// object ids are uint32 and the all-ones id marks "no home" in the
// partition's records. Past it, CapacityExceeded.
inline constexpr std::uint64_t kMaxFrameObjects = 0xFFFFFFFEull;  // 2^32 - 2

// Boxes of one query tree (BroadPhase's static and moving BoxTrees): a
// node's link spends its top bit on telling leaves from nodes.
inline constexpr std::uint32_t kMaxQueryTreeBoxes = 0x7FFFFFFFu;  // 2^31 - 1

// Objects a generated scenario (hbp::Scenario, `hbp run --scene`) may have:
// its state is ~160 bytes an object (shape, velocities) plus 24 a box, so
// 2^26 objects take ~12 GiB before the broad phase's own memory. Past it,
// InvalidInput up front rather than std::bad_alloc later.
inline constexpr std::uint32_t kMaxScenarioObjects = 1u << 26;  // 67,108,864

// Bits of a BroadPhase handle that name its slot; the other 8 are the
// slot's generation, which turns a stale handle into an error.
inline constexpr std::uint32_t kHandleSlotBits = 24;
// Live objects of one BroadPhase (static and moving together): the slots
// a handle can name, less the all-ones slot of kInvalidHandle.
inline constexpr std::uint32_t kMaxObjects = (1u << kHandleSlotBits) - 1;
static_assert(kMaxObjects <= kMaxQueryTreeBoxes && kMaxObjects <= kMaxFrameObjects,
              "a BroadPhase's objects fit its query trees and the hybrid system's frames");
// Collision layers: one bit each in a 32-bit mask per layer.
inline constexpr std::uint32_t kLayerCount = 32;

}  // namespace hbp
