// SPDX-License-Identifier: MIT
#pragma once
// The snapshot format of hbp::BroadPhase: its logical state to bytes
// (SnapshotSource) and back (BroadPhaseState). Derived structures (dense arrays, trees, caches, the
// hybrid system) are not stored: they are rebuilt from this state.
//
// Layout (little-endian; docs/broad-phase.md, "Snapshots"):
//   header, 32 bytes: magic "HBPSNAP\0", u32 version (1), u32 flags (0),
//     u64 size of the whole snapshot, u64 XXH64 (seed 0) of the bytes after
//     the header;
//   sections, each: 4 ASCII tag bytes, u32 flags (bit 0: optional), u64
//     payload length, the payload.
// Version 1 has nine sections, each required once, in any order: SLOT
// (slot table), FREE (free list), BOXS (boxes of the live objects), LAYR
// (layer table), PAIR (last update's lists), STAT (last update's stats),
// EDIT (stats counted since), ATTR (the objects whose filter, user data,
// margin or sweep differ from the defaults), DBLB (double precision: the
// double boxes of the live objects). A later version adds data as new sections; a
// reader skips an unknown section flagged optional and rejects an unknown
// required one. Reading checks everything (sizes, checksum, ranges, order,
// the free list against the table) and throws InvalidInput naming the first
// defect, so a state it returns is consistent.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/aabb_d.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/collision_filter.hpp"
#include "hbp/limits.hpp"

namespace hbp::detail {

// A live object's attributes when any differs from the defaults.
struct ObjectAttributes {
  std::uint32_t slot = 0;
  Filter filter;
  std::uint64_t user_data = 0;
  float margin = 0;
  bool swept = false;  // in a sweep: sweep_end is its last move_swept's box (grown)
  Aabb sweep_end{};
};

struct BroadPhaseState {
  // The slot table, by slot (HandleTable's arrays): kind (HandleTable::Kind),
  // generation, layer; free slots in push order (the last is reused first).
  std::vector<std::uint8_t> kind, generation, layer;
  std::vector<std::uint32_t> free_slots;
  std::vector<Aabb> boxes;  // by slot; a free slot's entry is not stored
  std::array<std::uint32_t, kLayerCount> collide_mask{};
  BroadPhaseUpdate last;  // the last completed update's lists
  BroadPhaseUpdateStats stats;
  // The stats counted since the last update: the counts, the live slots
  // already counted (increasing), and the live slots whose kind changed
  // since (increasing), each with whether it is counted in `moved`.
  std::uint32_t pending_moved = 0, pending_static_changes = 0;
  std::vector<std::uint32_t> counted;
  std::vector<std::uint32_t> kind_changed;
  std::vector<std::uint8_t> kind_changed_moved;
  std::vector<ObjectAttributes> attributes;  // by increasing slot
  bool double_precision = false;
  std::vector<AabbD> boxes_d;  // double precision: by slot (a free slot's is zero)
};

inline constexpr std::uint32_t kSnapshotVersion = 1;

// What write_snapshot reads: the same state, the large arrays as views of
// the BroadPhase's own (no copy), a box by slot (moving objects keep theirs
// in dense arrays).
struct SnapshotSource {
  std::span<const std::uint8_t> kind, generation, layer;
  std::span<const std::uint32_t> free_slots;
  std::function<Aabb(std::uint32_t slot)> box;  // of a live slot
  std::span<const std::uint32_t> collide_mask;  // kLayerCount
  const BroadPhaseUpdate* last = nullptr;
  BroadPhaseUpdateStats stats;
  std::uint32_t pending_moved = 0, pending_static_changes = 0;
  std::vector<std::uint32_t> counted;
  std::vector<std::uint32_t> kind_changed;
  std::vector<std::uint8_t> kind_changed_moved;
  std::vector<ObjectAttributes> attributes;
  std::function<AabbD(std::uint32_t slot)> box_d;  // double precision only (else empty)
};

// The sizes a snapshot's length follows from (so it is known without
// writing it), and that length in bytes.
struct SnapshotShape {
  std::size_t slots = 0, free_slots = 0, pairs = 0, created = 0, removed = 0, counted = 0, kind_changed = 0;
  std::size_t attributes = 0;
  bool double_precision = false;
};
SnapshotShape shape_of(const SnapshotSource& source);
std::size_t snapshot_size(const SnapshotShape& shape);
// Writes the snapshot into out[0, snapshot_size(shape_of(source))) (out is
// at least that long).
void write_snapshot(const SnapshotSource& source, std::span<std::byte> out);
// The state a snapshot holds; InvalidInput (message prefixed by `call`)
// naming what is wrong with malformed, truncated or corrupted data.
BroadPhaseState read_snapshot(std::span<const std::byte> data, const char* call);

}  // namespace hbp::detail
