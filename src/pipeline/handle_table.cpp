// SPDX-License-Identifier: MIT
#include "pipeline/handle_table.hpp"

#include <cstdio>
#include <utility>

namespace hbp::detail {

namespace {
std::string hex(Handle h) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", h);
  return buf;
}
}  // namespace

std::string HandleTable::defect(Handle h) const {
  const std::uint32_t s = slot_of(h);
  const unsigned gen = h >> kHandleSlotBits;
  if (s >= slots()) return "unknown handle " + hex(h) + " (slot " + std::to_string(s) + " was never used)";
  if (handle_of(s) != h || kind_[s] == kFree) {
    std::string why = "stale handle " + hex(h) + " (generation " + std::to_string(gen) + " of slot " +
                      std::to_string(s) + " was removed; ";
    why += kind_[s] == kFree ? "the slot is free)" : "the slot now holds " + hex(handle_of(s)) + ")";
    return why;
  }
  return {};
}

std::uint32_t HandleTable::allocate(Kind kind, std::uint8_t layer) {
  std::uint32_t s;
  if (!free_.empty()) {
    s = free_.back();
    free_.pop_back();
  } else {
    s = slots();
    kind_.push_back(kFree);
    generation_.push_back(0);
    layer_.push_back(0);
    index_.push_back(kNoIndex);
  }
  kind_[s] = kind;
  layer_[s] = layer;
  index_[s] = kNoIndex;
  ++live_;
  return s;
}

void HandleTable::release(std::uint32_t slot) {
  kind_[slot] = kFree;
  ++generation_[slot];  // wraps after 256 reuses of one slot
  index_[slot] = kNoIndex;
  free_.push_back(slot);
  --live_;
}

void HandleTable::clear() { *this = HandleTable(); }

void HandleTable::assign(std::vector<std::uint8_t> kinds, std::vector<std::uint8_t> generations,
                         std::vector<std::uint8_t> layers, std::vector<std::uint32_t> free_slots) {
  live_ = kinds.size() - free_slots.size();
  kind_ = std::move(kinds);
  generation_ = std::move(generations);
  layer_ = std::move(layers);
  free_ = std::move(free_slots);
  index_.assign(kind_.size(), kNoIndex);
}

}  // namespace hbp::detail
