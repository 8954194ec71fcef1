// SPDX-License-Identifier: MIT
#pragma once
// BroadPhase's slot table: which slots hold a live object, each slot's
// generation (the high 8 bits of its handles), kind, layer and index in the
// dense arrays of its kind. Freed slots are reused last-freed first with the
// generation advanced, so a handle kept past remove() is recognised as stale.
#include <cstdint>
#include <string>
#include <vector>

#include "hbp/broad_phase.hpp"

namespace hbp::detail {

class HandleTable {
 public:
  enum Kind : std::uint8_t { kFree = 0, kMoving = 1, kStatic = 2 };
  static constexpr std::uint32_t kSlotMask = (1u << kHandleSlotBits) - 1;
  static constexpr std::uint32_t kNoIndex = 0xFFFFFFFFu;

  static std::uint32_t slot_of(Handle h) { return h & kSlotMask; }
  Handle handle_of(std::uint32_t slot) const {
    return slot | (static_cast<Handle>(generation_[slot]) << kHandleSlotBits);
  }

  std::uint32_t slots() const { return static_cast<std::uint32_t>(kind_.size()); }
  std::size_t live() const { return live_; }
  bool live(Handle h) const {
    const std::uint32_t s = slot_of(h);
    return s < slots() && kind_[s] != kFree && handle_of(s) == h;
  }
  // Empty when h names a live object, else why not ("unknown", "stale ...").
  std::string defect(Handle h) const;

  // Takes a free slot (or a new one) for an object of `kind`.
  std::uint32_t allocate(Kind kind, std::uint8_t layer);
  // Frees the slot and advances its generation.
  void release(std::uint32_t slot);
  void clear();

  Kind kind(std::uint32_t slot) const { return static_cast<Kind>(kind_[slot]); }
  std::uint8_t layer(std::uint32_t slot) const { return layer_[slot]; }
  void set_layer(std::uint32_t slot, std::uint8_t layer) { layer_[slot] = layer; }
  std::uint32_t index(std::uint32_t slot) const { return index_[slot]; }
  void set_index(std::uint32_t slot, std::uint32_t index) { index_[slot] = index; }
  const std::uint8_t* layers() const { return layer_.data(); }
  // A live object becomes static or moving; it has no dense index until the
  // arrays of its new kind are gathered again.
  void set_kind(std::uint32_t slot, Kind kind) {
    kind_[slot] = kind;
    index_[slot] = kNoIndex;
  }

  // The table as a snapshot holds it (by slot; the free list in push order,
  // its last entry reused first), and back. assign takes arrays the caller
  // has checked: the free list names exactly the free slots, once each.
  const std::vector<std::uint8_t>& kinds() const { return kind_; }
  const std::vector<std::uint8_t>& generations() const { return generation_; }
  const std::vector<std::uint8_t>& layer_table() const { return layer_; }
  const std::vector<std::uint32_t>& free_slots() const { return free_; }
  void assign(std::vector<std::uint8_t> kinds, std::vector<std::uint8_t> generations,
              std::vector<std::uint8_t> layers, std::vector<std::uint32_t> free_slots);

 private:
  std::vector<std::uint8_t> kind_, generation_, layer_;
  std::vector<std::uint32_t> index_;
  std::vector<std::uint32_t> free_;  // freed slots, reused last first
  std::size_t live_ = 0;
};

}  // namespace hbp::detail
