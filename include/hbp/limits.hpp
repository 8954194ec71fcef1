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

// Bits of a BroadPhase handle that name its slot; the other 8 are the
// slot's generation, which turns a stale handle into an error.
inline constexpr std::uint32_t kHandleSlotBits = 24;
// Live objects of one BroadPhase (static and moving together): the slots
// a handle can name, less the all-ones slot of kInvalidHandle.
inline constexpr std::uint32_t kMaxObjects = (1u << kHandleSlotBits) - 1;
// Collision layers: one bit each in a 32-bit mask per layer.
inline constexpr std::uint32_t kLayerCount = 32;

}  // namespace hbp
