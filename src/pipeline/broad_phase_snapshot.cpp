// SPDX-License-Identifier: MIT
#include "pipeline/broad_phase_snapshot.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "hbp/error.hpp"
#include "pipeline/handle_table.hpp"
#include "support/xxh64.hpp"

namespace hbp::detail {

namespace {

constexpr char kMagic[8] = {'H', 'B', 'P', 'S', 'N', 'A', 'P', '\0'};
constexpr std::size_t kHeaderBytes = 32;
constexpr std::size_t kSectionHeaderBytes = 16;
constexpr std::uint32_t kOptionalSection = 1u;

// Version 1's sections, in the order they are written.
enum Section { kSlot, kFree, kBoxes, kLayers, kPairs, kStats, kEdits, kAttributes, kDoubles, kSectionCount };
constexpr const char* kTags[kSectionCount] = {"SLOT", "FREE", "BOXS", "LAYR", "PAIR",
                                              "STAT", "EDIT", "ATTR", "DBLB"};
// One ATTR entry: slot, swept, category, mask, group, margin, user data,
// the sweep's end box.
constexpr std::size_t kAttributeBytes = 4 + 4 + 8 + 8 + 4 + 4 + 8 + sizeof(Aabb);

// Words of `size` bytes are stored little-endian: one copy on a
// little-endian host, byte-reversed words on a big-endian one.
void copy_words(void* dst, const void* src, std::size_t count, std::size_t size) {
  if constexpr (std::endian::native == std::endian::little) {
    if (count) std::memcpy(dst, src, count * size);
  } else {
    auto* d = static_cast<unsigned char*>(dst);
    const auto* s = static_cast<const unsigned char*>(src);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t b = 0; b < size; ++b) d[i * size + b] = s[i * size + size - 1 - b];
  }
}

class Writer {
 public:
  explicit Writer(std::byte* out) : p_(out) {}
  template <class T>
  void put(T v) {
    copy_words(p_, &v, 1, sizeof v);
    p_ += sizeof v;
  }
  // count words of sizeof(Word) bytes from src.
  template <class Word>
  void put_words(const void* src, std::size_t count) {
    copy_words(p_, src, count, sizeof(Word));
    p_ += count * sizeof(Word);
  }
  void put_bytes(const void* src, std::size_t n) {
    if (n) std::memcpy(p_, src, n);
    p_ += n;
  }
  std::byte* at() const { return p_; }

 private:
  std::byte* p_;
};

// Reads one section's payload; a read past its end names the section and the field.
class Reader {
 public:
  Reader(const std::byte* p, std::size_t n, std::string where) : p_(p), end_(p + n), where_(std::move(where)) {}
  [[noreturn]] void fail(const std::string& why) const { throw InvalidInput(where_ + why); }
  void need(std::size_t bytes, const char* field) const {
    if (static_cast<std::size_t>(end_ - p_) < bytes)
      fail(std::string("truncated: ") + field + " needs " + std::to_string(bytes) + " bytes, " +
           std::to_string(end_ - p_) + " left");
  }
  template <class T>
  T get(const char* field) {
    need(sizeof(T), field);
    T v;
    copy_words(&v, p_, 1, sizeof v);
    p_ += sizeof v;
    return v;
  }
  template <class Word>
  void get_words(void* dst, std::size_t count, const char* field) {
    if (count > static_cast<std::size_t>(end_ - p_) / sizeof(Word)) need(count * sizeof(Word), field);
    copy_words(dst, p_, count, sizeof(Word));
    p_ += count * sizeof(Word);
  }
  // The next n bytes, read in place.
  const std::uint8_t* take(std::size_t n, const char* field) {
    need(n, field);
    const auto* at = reinterpret_cast<const std::uint8_t*>(p_);
    p_ += n;
    return at;
  }
  void finish() const {
    if (p_ != end_) fail(std::to_string(end_ - p_) + " bytes after the last field");
  }

 private:
  const std::byte* p_;
  const std::byte* end_;
  std::string where_;
};

std::size_t live_count(const BroadPhaseState& s) { return s.kind.size() - s.free_slots.size(); }

std::size_t payload_bytes(const SnapshotShape& s, int section) {
  switch (section) {
    case kSlot: return 4 + 3 * s.slots;
    case kFree: return 4 + 4 * s.free_slots;
    case kBoxes: return 4 + sizeof(Aabb) * (s.slots - s.free_slots);
    case kLayers: return 4 + 4 * kLayerCount;
    case kPairs: return 24 + sizeof(Pair) * (s.pairs + s.created + s.removed);
    case kStats: return 16 + 8;
    case kEdits: return 16 + 4 * s.counted + 8 * s.kind_changed;
    case kAttributes: return 4 + kAttributeBytes * s.attributes;
    case kDoubles: return 8 + (s.double_precision ? sizeof(AabbD) * (s.slots - s.free_slots) : 0);
  }
  return 0;
}

void write_section(Writer& w, const SnapshotSource& s, int section) {
  const auto n32 = [](std::size_t n) { return static_cast<std::uint32_t>(n); };
  switch (section) {
    case kSlot:
      w.put(n32(s.kind.size()));
      w.put_bytes(s.kind.data(), s.kind.size());
      w.put_bytes(s.generation.data(), s.generation.size());
      w.put_bytes(s.layer.data(), s.layer.size());
      break;
    case kFree:
      w.put(n32(s.free_slots.size()));
      w.put_words<std::uint32_t>(s.free_slots.data(), s.free_slots.size());
      break;
    case kBoxes:
      w.put(n32(s.kind.size() - s.free_slots.size()));
      for (std::uint32_t slot = 0; slot < s.kind.size(); ++slot) {
        if (s.kind[slot] == HandleTable::kFree) continue;
        const Aabb b = s.box(slot);
        w.put_words<float>(&b, 6);
      }
      break;
    case kLayers:
      w.put(kLayerCount);
      w.put_words<std::uint32_t>(s.collide_mask.data(), kLayerCount);
      break;
    case kPairs: {
      const std::vector<Pair>* lists[3] = {&s.last->pairs, &s.last->created, &s.last->removed};
      for (const auto* list : lists) w.put(static_cast<std::uint64_t>(list->size()));
      for (const auto* list : lists) w.put_words<std::uint32_t>(list->data(), 2 * list->size());
      break;
    }
    case kStats:
      w.put(s.stats.moving);
      w.put(s.stats.statics);
      w.put(s.stats.moved);
      w.put(s.stats.static_changes);
      w.put(s.stats.wall_ms);
      break;
    case kEdits:
      w.put(s.pending_moved);
      w.put(s.pending_static_changes);
      w.put(n32(s.counted.size()));
      w.put(n32(s.kind_changed.size()));
      w.put_words<std::uint32_t>(s.counted.data(), s.counted.size());
      for (std::size_t i = 0; i < s.kind_changed.size(); ++i) {
        w.put(s.kind_changed[i]);
        w.put(static_cast<std::uint32_t>(s.kind_changed_moved[i]));
      }
      break;
    case kAttributes:
      w.put(n32(s.attributes.size()));
      for (const ObjectAttributes& a : s.attributes) {
        w.put(a.slot);
        w.put(static_cast<std::uint32_t>(a.swept));
        w.put(a.filter.category);
        w.put(a.filter.mask);
        w.put(a.filter.group);
        w.put(a.margin);
        w.put(a.user_data);
        w.put_words<float>(&a.sweep_end, 6);
      }
      break;
    case kDoubles: {
      const bool doubles = static_cast<bool>(s.box_d);
      w.put(static_cast<std::uint32_t>(doubles));
      w.put(n32(doubles ? s.kind.size() - s.free_slots.size() : 0));
      if (!doubles) break;
      for (std::uint32_t slot = 0; slot < s.kind.size(); ++slot) {
        if (s.kind[slot] == HandleTable::kFree) continue;
        const AabbD b = s.box_d(slot);
        w.put_words<double>(&b, 6);
      }
      break;
    }
  }
}

std::string hex(std::uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%llx", static_cast<unsigned long long>(v));
  return buf;
}

std::string pair_text(const Pair& p) {
  std::string t = std::to_string(p.a);
  t.insert(t.begin(), '(');
  t.append(", ").append(std::to_string(p.b)).append(")");
  return t;
}

// ---- reading: one function per section, each checking its own fields ----

void read_slots(Reader& r, BroadPhaseState& s) {
  const std::uint32_t slots = r.get<std::uint32_t>("the slot count");
  if (slots > (1u << kHandleSlotBits))
    r.fail(std::to_string(slots) + " slots, more than the " + std::to_string(1u << kHandleSlotBits) +
           " a handle can name");
  r.need(3 * std::size_t{slots}, "the slot arrays");
  for (auto* array : {&s.kind, &s.generation, &s.layer}) {
    const std::uint8_t* at = r.take(slots, "the slot arrays");
    array->assign(at, at + slots);
  }
  r.finish();
  for (std::uint32_t i = 0; i < slots; ++i) {
    if (s.kind[i] > HandleTable::kStatic)
      r.fail("slot " + std::to_string(i) + ": kind " + std::to_string(s.kind[i]) + " (0 free, 1 moving, 2 static)");
    if (s.layer[i] >= kLayerCount)
      r.fail("slot " + std::to_string(i) + ": layer " + std::to_string(s.layer[i]) + " out of range (0.." +
             std::to_string(kLayerCount - 1) + ")");
  }
}

// After SLOT and FREE: the free list names every free slot exactly once.
void check_free(Reader& r, const BroadPhaseState& s) {
  const std::size_t slots = s.kind.size();
  std::vector<std::uint8_t> listed(slots, 0);
  for (std::size_t i = 0; i < s.free_slots.size(); ++i) {
    const std::uint32_t f = s.free_slots[i];
    if (f < slots && s.kind[f] == HandleTable::kFree && !listed[f]) {
      listed[f] = 1;
      continue;
    }
    if (f >= slots) r.fail("entry " + std::to_string(i) + ": slot " + std::to_string(f) + " of " + std::to_string(slots));
    if (s.kind[f] != HandleTable::kFree)
      r.fail("entry " + std::to_string(i) + ": slot " + std::to_string(f) + " holds a live object");
    r.fail("entry " + std::to_string(i) + ": slot " + std::to_string(f) + " listed twice");
  }
  const std::size_t free_in_table = static_cast<std::size_t>(std::count(s.kind.begin(), s.kind.end(), 0));
  if (free_in_table != s.free_slots.size())
    r.fail(std::to_string(s.free_slots.size()) + " free slots listed, the slot table has " +
           std::to_string(free_in_table));
  if (slots - free_in_table > kMaxObjects)
    r.fail(std::to_string(slots - free_in_table) + " live objects, more than " + std::to_string(kMaxObjects));
}

// After SLOT (read first): the free list, checked against the slot table.
void read_free(Reader& r, BroadPhaseState& s) {
  const std::uint32_t n = r.get<std::uint32_t>("the free slot count");
  r.need(4 * std::size_t{n}, "the free slots");  // before sizing anything by a count read
  s.free_slots.resize(n);
  r.get_words<std::uint32_t>(s.free_slots.data(), n, "the free slots");
  r.finish();
  check_free(r, s);
}

void read_boxes(Reader& r, BroadPhaseState& s) {
  const std::uint32_t n = r.get<std::uint32_t>("the box count");
  const std::size_t live = live_count(s);
  if (n != live) r.fail(std::to_string(n) + " boxes for " + std::to_string(live) + " live objects");
  r.need(sizeof(Aabb) * std::size_t{n}, "the boxes");
  // One pass: each box read, checked and appended (a free slot's is zero).
  const std::size_t slots = s.kind.size();
  s.boxes.clear();
  s.boxes.reserve(slots);
  for (std::size_t i = 0; i < slots; ++i) {
    Aabb b{};
    if (s.kind[i] != HandleTable::kFree) {
      r.get_words<float>(&b, 6, "the boxes");
      if (const char* d = box_defect(b)) r.fail("slot " + std::to_string(i) + ": " + d);
    }
    s.boxes.push_back(b);
  }
  r.finish();
}

void read_layers(Reader& r, BroadPhaseState& s) {
  const std::uint32_t n = r.get<std::uint32_t>("the layer count");
  if (n != kLayerCount) r.fail(std::to_string(n) + " layers, this library has " + std::to_string(kLayerCount));
  r.get_words<std::uint32_t>(s.collide_mask.data(), kLayerCount, "the layer table");
  r.finish();
  for (std::uint32_t a = 0; a < kLayerCount; ++a)
    for (std::uint32_t b = 0; b < kLayerCount; ++b)
      if (((s.collide_mask[a] >> b) & 1u) != ((s.collide_mask[b] >> a) & 1u))
        r.fail("layers " + std::to_string(a) + " and " + std::to_string(b) + " collide one way only");
}

// A list of handle pairs: a < b, strictly increasing, slots in the table.
void check_pairs(Reader& r, const std::vector<Pair>& list, const char* name, std::size_t slots) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Pair& p = list[i];
    const bool ordered = p.a < p.b, after = i == 0 || list[i - 1] < p;
    const bool in_table = HandleTable::slot_of(p.a) < slots && HandleTable::slot_of(p.b) < slots;
    if (ordered && after && in_table) continue;
    const std::string at = std::string(name) + " row " + std::to_string(i) + " " + pair_text(p) + ": ";
    if (!ordered) r.fail(at + "not a < b");
    if (!after) r.fail(at + "not after the row before (sorted, no repeats)");
    r.fail(at + "a handle names a slot the table does not have");
  }
}

void read_pairs(Reader& r, BroadPhaseState& s) {
  std::uint64_t n[3];
  for (auto& c : n) c = r.get<std::uint64_t>("the pair counts");
  std::vector<Pair>* lists[3] = {&s.last.pairs, &s.last.created, &s.last.removed};
  const char* names[3] = {"pairs", "created", "removed"};
  for (int l = 0; l < 3; ++l) {
    if (n[l] > (std::uint64_t{1} << 40)) r.fail(std::string(names[l]) + ": " + std::to_string(n[l]) + " pairs");
    r.need(sizeof(Pair) * n[l], names[l]);
    lists[l]->resize(n[l]);
    r.get_words<std::uint32_t>(lists[l]->data(), 2 * n[l], names[l]);
  }
  r.finish();
  for (int l = 0; l < 3; ++l) check_pairs(r, *lists[l], names[l], s.kind.size());
  // created within pairs, removed outside them (both sorted).
  std::size_t j = 0;
  for (std::size_t i = 0; i < s.last.created.size(); ++i) {
    while (j < s.last.pairs.size() && s.last.pairs[j] < s.last.created[i]) ++j;
    if (j == s.last.pairs.size() || s.last.pairs[j] != s.last.created[i])
      r.fail("created row " + std::to_string(i) + " " + pair_text(s.last.created[i]) + " is not in pairs");
  }
  j = 0;
  for (std::size_t i = 0; i < s.last.removed.size(); ++i) {
    while (j < s.last.pairs.size() && s.last.pairs[j] < s.last.removed[i]) ++j;
    if (j < s.last.pairs.size() && s.last.pairs[j] == s.last.removed[i])
      r.fail("removed row " + std::to_string(i) + " " + pair_text(s.last.removed[i]) + " is also in pairs");
  }
}

void read_stats(Reader& r, BroadPhaseState& s) {
  s.stats.moving = r.get<std::uint32_t>("moving");
  s.stats.statics = r.get<std::uint32_t>("statics");
  s.stats.moved = r.get<std::uint32_t>("moved");
  s.stats.static_changes = r.get<std::uint32_t>("static_changes");
  s.stats.wall_ms = r.get<double>("wall_ms");
  r.finish();
  if (!(s.stats.wall_ms >= 0) || !std::isfinite(s.stats.wall_ms)) r.fail("wall_ms is negative or not finite");
}

// Slots strictly increasing and live.
void check_slot_list(Reader& r, const std::vector<std::uint32_t>& list, const char* name, const BroadPhaseState& s) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::uint32_t v = list[i];
    const bool live = v < s.kind.size() && s.kind[v] != HandleTable::kFree, after = i == 0 || list[i - 1] < v;
    if (live && after) continue;
    const std::string at = std::string(name) + " row " + std::to_string(i) + ": slot " + std::to_string(v);
    if (!live) r.fail(at + " holds no live object");
    r.fail(at + " not after the row before (increasing)");
  }
}

void read_edits(Reader& r, BroadPhaseState& s) {
  s.pending_moved = r.get<std::uint32_t>("moved");
  s.pending_static_changes = r.get<std::uint32_t>("static_changes");
  const std::uint32_t n_counted = r.get<std::uint32_t>("the counted slot count");
  const std::uint32_t n_kind = r.get<std::uint32_t>("the kind change count");
  r.need(4 * std::size_t{n_counted}, "the counted slots");  // before sizing anything by a count read
  s.counted.resize(n_counted);
  r.get_words<std::uint32_t>(s.counted.data(), n_counted, "the counted slots");
  r.need(8 * std::size_t{n_kind}, "the kind changes");
  s.kind_changed.resize(n_kind);
  s.kind_changed_moved.resize(n_kind);
  for (std::uint32_t i = 0; i < n_kind; ++i) {
    s.kind_changed[i] = r.get<std::uint32_t>("a kind change's slot");
    const std::uint32_t moved = r.get<std::uint32_t>("a kind change's flag");
    if (moved > 1) r.fail("kind change row " + std::to_string(i) + ": flag " + std::to_string(moved) + " (0 or 1)");
    s.kind_changed_moved[i] = static_cast<std::uint8_t>(moved);
  }
  r.finish();
  check_slot_list(r, s.counted, "counted", s);
  check_slot_list(r, s.kind_changed, "kind change", s);
}

void read_attributes(Reader& r, BroadPhaseState& s) {
  const std::uint32_t n = r.get<std::uint32_t>("the attribute count");
  r.need(kAttributeBytes * std::size_t{n}, "the attributes");  // before sizing anything by a count read
  s.attributes.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    ObjectAttributes& a = s.attributes[i];
    a.slot = r.get<std::uint32_t>("a slot");
    const std::uint32_t swept = r.get<std::uint32_t>("a sweep flag");
    a.filter.category = r.get<std::uint64_t>("a category");
    a.filter.mask = r.get<std::uint64_t>("a mask");
    a.filter.group = r.get<std::int32_t>("a group");
    a.margin = r.get<float>("a margin");
    a.user_data = r.get<std::uint64_t>("a user data");
    r.get_words<float>(&a.sweep_end, 6, "a sweep's end box");
    const std::string at = "attribute row " + std::to_string(i) + " (slot " + std::to_string(a.slot) + "): ";
    const bool live = a.slot < s.kind.size() && s.kind[a.slot] != HandleTable::kFree;
    if (!live) r.fail(at + "holds no live object");
    if (i > 0 && s.attributes[i - 1].slot >= a.slot) r.fail(at + "not after the row before (increasing)");
    if (swept > 1) r.fail(at + "sweep flag " + std::to_string(swept) + " (0 or 1)");
    a.swept = swept != 0;
    if (!(a.margin >= 0) || !std::isfinite(a.margin)) r.fail(at + "margin is negative or not finite");
    if (a.swept) {
      if (const char* d = box_defect(a.sweep_end)) r.fail(at + "sweep end box: " + d);
    }
  }
  r.finish();
}

void read_doubles(Reader& r, BroadPhaseState& s) {
  const std::uint32_t flag = r.get<std::uint32_t>("the double-precision flag");
  const std::uint32_t n = r.get<std::uint32_t>("the double box count");
  if (flag > 1) r.fail("double-precision flag " + std::to_string(flag) + " (0 or 1)");
  s.double_precision = flag != 0;
  const std::size_t live = live_count(s);
  if (n != (s.double_precision ? live : 0))
    r.fail(std::to_string(n) + " double boxes for " + std::to_string(live) + " live objects" +
           (s.double_precision ? "" : " of a float snapshot"));
  r.need(sizeof(AabbD) * std::size_t{n}, "the double boxes");
  if (!s.double_precision) {
    r.finish();
    return;
  }
  const std::size_t slots = s.kind.size();
  s.boxes_d.assign(slots, AabbD{});
  for (std::size_t i = 0; i < slots; ++i) {
    if (s.kind[i] == HandleTable::kFree) continue;
    r.get_words<double>(&s.boxes_d[i], 6, "the double boxes");
    if (const char* d = box_defect(s.boxes_d[i])) r.fail("slot " + std::to_string(i) + ": " + d);
  }
  r.finish();
}

}  // namespace

SnapshotShape shape_of(const SnapshotSource& s) {
  return {.slots = s.kind.size(),
          .free_slots = s.free_slots.size(),
          .pairs = s.last->pairs.size(),
          .created = s.last->created.size(),
          .removed = s.last->removed.size(),
          .counted = s.counted.size(),
          .kind_changed = s.kind_changed.size(),
          .attributes = s.attributes.size(),
          .double_precision = static_cast<bool>(s.box_d)};
}

std::size_t snapshot_size(const SnapshotShape& shape) {
  std::size_t n = kHeaderBytes;
  for (int k = 0; k < kSectionCount; ++k) n += kSectionHeaderBytes + payload_bytes(shape, k);
  return n;
}

void write_snapshot(const SnapshotSource& state, std::span<std::byte> out) {
  const SnapshotShape shape = shape_of(state);
  const std::size_t size = snapshot_size(shape);
  if (out.size() < size) throw InvalidInput("write_snapshot: the buffer is smaller than the snapshot");
  Writer w(out.data());
  w.put_bytes(kMagic, sizeof kMagic);
  w.put(kSnapshotVersion);
  w.put(std::uint32_t{0});
  w.put(static_cast<std::uint64_t>(size));
  w.put(std::uint64_t{0});  // the checksum, once the sections are written
  for (int k = 0; k < kSectionCount; ++k) {
    w.put_bytes(kTags[k], 4);
    w.put(std::uint32_t{0});
    w.put(static_cast<std::uint64_t>(payload_bytes(shape, k)));
    write_section(w, state, k);
  }
  const std::uint64_t sum = xxh64(out.data() + kHeaderBytes, size - kHeaderBytes);
  Writer(out.data() + 24).put(sum);
}

BroadPhaseState read_snapshot(std::span<const std::byte> data, const char* call) {
  const std::string prefix = std::string(call) + ": ";
  const auto fail = [&](const std::string& why) { throw InvalidInput(prefix + why); };
  if (data.size() < sizeof kMagic || std::memcmp(data.data(), kMagic, sizeof kMagic) != 0)
    fail("not a BroadPhase snapshot (no \"HBPSNAP\" magic at the start)");
  Reader header(data.data() + sizeof kMagic, std::min(data.size(), kHeaderBytes) - sizeof kMagic, prefix + "header: ");
  const std::uint32_t version = header.get<std::uint32_t>("the version");
  if (version != kSnapshotVersion)
    fail("snapshot version " + std::to_string(version) + ", this library reads version " +
         std::to_string(kSnapshotVersion));
  const std::uint32_t flags = header.get<std::uint32_t>("the flags");
  if (flags != 0) fail("header flags " + hex(flags) + " (version 1 has none)");
  const std::uint64_t size = header.get<std::uint64_t>("the size");
  const std::uint64_t sum = header.get<std::uint64_t>("the checksum");
  if (data.size() < size)
    fail("truncated: " + std::to_string(data.size()) + " bytes, the header says " + std::to_string(size));
  if (data.size() > size)
    fail(std::to_string(data.size() - size) + " bytes after the end the header gives (" + std::to_string(size) +
         " bytes)");
  if (size < kHeaderBytes) fail("the header's size " + std::to_string(size) + " is smaller than the header");
  const std::uint64_t actual = xxh64(data.data() + kHeaderBytes, data.size() - kHeaderBytes);
  if (actual != sum) fail("checksum mismatch (header " + hex(sum) + ", data " + hex(actual) + "): the data is corrupted");

  // The sections, by tag.
  struct Found {
    const std::byte* payload = nullptr;
    std::size_t length = 0;
    bool seen = false;
  };
  Found found[kSectionCount];
  std::size_t at = kHeaderBytes;
  while (at < data.size()) {
    if (data.size() - at < kSectionHeaderBytes)
      fail("truncated: a section header at byte " + std::to_string(at) + " needs 16 bytes, " +
           std::to_string(data.size() - at) + " left");
    char tag[5] = {};
    std::memcpy(tag, data.data() + at, 4);
    Reader h(data.data() + at + 4, 12, prefix + "section header at byte " + std::to_string(at) + ": ");
    const std::uint32_t section_flags = h.get<std::uint32_t>("flags");
    const std::uint64_t length = h.get<std::uint64_t>("length");
    const std::size_t payload_at = at + kSectionHeaderBytes;
    const std::string name = std::string("section '") + tag + "'";
    if (length > data.size() - payload_at)
      fail("truncated: " + name + " at byte " + std::to_string(at) + " says " + std::to_string(length) +
           " bytes, " + std::to_string(data.size() - payload_at) + " left");
    if (section_flags & ~kOptionalSection) fail(name + ": unknown flags " + hex(section_flags));
    int k = 0;
    while (k < kSectionCount && std::memcmp(tag, kTags[k], 4) != 0) ++k;
    if (k == kSectionCount) {
      if (!(section_flags & kOptionalSection))
        fail(name + " is required but unknown to this library (version " + std::to_string(kSnapshotVersion) + ")");
    } else {
      if (found[k].seen) fail(name + " appears twice");
      found[k] = {data.data() + payload_at, static_cast<std::size_t>(length), true};
    }
    at = payload_at + static_cast<std::size_t>(length);
  }
  for (int k = 0; k < kSectionCount; ++k)
    if (!found[k].seen) fail(std::string("no '") + kTags[k] + "' section");

  // Each section's reader, indexed by Section, read in that order: the
  // dependency order (the slot table first, then what refers to it).
  BroadPhaseState s;
  using SectionReader = void (*)(Reader&, BroadPhaseState&);
  static constexpr SectionReader kReaders[kSectionCount] = {read_slots, read_free,  read_boxes,      read_layers,
                                                            read_pairs, read_stats, read_edits,      read_attributes,
                                                            read_doubles};
  for (int k = 0; k < kSectionCount; ++k) {
    Reader r(found[k].payload, found[k].length, prefix + "section '" + kTags[k] + "': ");
    kReaders[k](r, s);
  }
  return s;
}

}  // namespace hbp::detail
