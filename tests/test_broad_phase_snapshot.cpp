// SPDX-License-Identifier: MIT
// BroadPhase::snapshot / restore / from_snapshot: randomized runs (the
// brute-force session of broad_phase_session.hpp) snapshot the world at
// random points, mid-frame included, restore into fresh objects and into the
// same object after more edits, and check that the next 100 frames (pairs,
// created, removed, stats, handles returned by add) are the original's.
// Malformed data (truncated, corrupted, wrong version, inconsistent fields
// with a valid checksum) is rejected naming the defect, the object unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "broad_phase_session.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "support/xxh64.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Handle;
using hbp::Pair;
using hbp::test::Session;
using Bytes = std::vector<std::byte>;

constexpr std::size_t kTarget = 150;

// A frame's lists as an update returned them.
struct Frame {
  std::vector<Pair> pairs, created, removed;
  bool operator==(const Frame&) const = default;
};

// Occasionally a new pair filter (or none): the snapshot does not hold it.
void maybe_change_filter(Session& s) {
  if (s.rng() % 40 != 0) return;
  if (s.rng() % 2)
    s.set_filter({});
  else
    s.set_filter([m = 3 + s.rng() % 4](Handle a, Handle b) { return (a ^ b) % m != 0; });
}

// The rest of the current frame and `frames` - 1 more, each checked against
// the reference; returns every frame's lists (of the first system).
std::vector<Frame> continue_for(Session& s, int frames) {
  std::vector<Frame> out;
  for (int f = 0; f < frames; ++f) {
    if (f > 0) maybe_change_filter(s);
    s.random_edits(kTarget);
    if (testing::Test::HasFatalFailure()) return out;
    s.check_frame();
    if (testing::Test::HasFatalFailure()) return out;
    const hbp::BroadPhaseUpdate& u = s.systems.front()->last_update();
    out.push_back({u.pairs, u.created, u.removed});
  }
  return out;
}

void expect_same_stats(const BroadPhase& a, const BroadPhase& b) {
  EXPECT_EQ(a.stats().moving, b.stats().moving);
  EXPECT_EQ(a.stats().statics, b.stats().statics);
  EXPECT_EQ(a.stats().moved, b.stats().moved);
  EXPECT_EQ(a.stats().static_changes, b.stats().static_changes);
  EXPECT_EQ(a.stats().wall_ms, b.stats().wall_ms);
}

void run(unsigned seed, int rounds) {
  BroadPhase world({.threads = 1});
  Session s(seed, 14, {&world});
  s.add(kTarget / 2, false, 0);
  s.add(kTarget / 4, true, 1);
  // Another history for the object restored over (its own edits, filter, layers).
  BroadPhase other({.threads = 2});
  Session o(seed + 1000, 10, {&other});
  o.add(kTarget, false, 2);
  std::uint64_t checked_frames = 0;
  for (int round = 0; round < rounds; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    // Some frames of the original alone.
    continue_for(s, 1 + static_cast<int>(s.rng() % 20));
    continue_for(o, 2);
    if (testing::Test::HasFatalFailure()) return;
    // Snapshot in the middle of a frame (edits pending) or right after an update.
    if (s.rng() % 3 != 0) s.random_edits(kTarget);
    if (testing::Test::HasFatalFailure()) return;
    const Bytes snap = world.snapshot();
    ASSERT_EQ(snap.size(), world.snapshot_size());
    const Session at_snapshot = s;

    // A fresh object and one with another history, given the current filter.
    BroadPhase fresh = BroadPhase::from_snapshot(snap, {.threads = 2});
    fresh.set_pair_filter(s.ref.filter);
    other.set_pair_filter(s.ref.filter);
    other.restore(snap);
    for (BroadPhase* r : {&fresh, &other}) {
      ASSERT_TRUE(r->snapshot() == snap) << "a restored object's snapshot is the snapshot it was restored from";
      EXPECT_EQ(r->size(), world.size());
      EXPECT_EQ(r->last_update().pairs, world.last_update().pairs);
      EXPECT_EQ(r->last_update().created, world.last_update().created);
      EXPECT_EQ(r->last_update().removed, world.last_update().removed);
      expect_same_stats(*r, world);
    }
    s.systems = {&world, &fresh, &other};
    const std::vector<Frame> original = continue_for(s, 100);
    if (testing::Test::HasFatalFailure()) return;
    checked_frames += original.size();

    // The original itself, after those 100 frames of edits, restored: the
    // same 100 frames again.
    world.set_pair_filter(at_snapshot.ref.filter);
    world.restore(snap);
    s = at_snapshot;
    s.systems = {&world};
    const std::vector<Frame> again = continue_for(s, 100);
    if (testing::Test::HasFatalFailure()) return;
    ASSERT_TRUE(again == original);
    o.systems = {&other};
    o.ref = s.ref;  // `other` now continues the restored world's history
    o.live = s.live;
  }
  EXPECT_GE(checked_frames, 100u * static_cast<std::uint64_t>(rounds));
  EXPECT_GT(s.events_seen, 0u);
}

TEST(BroadPhaseSnapshot, RandomRunsRestoreToTheSameNextFrames) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(seed);
    run(seed, 8);
    if (HasFatalFailure()) return;
  }
}

// A world with every kind of state: moving and static objects, sleepers,
// freed slots, layers, a layer table, pairs, pending edits.
struct Built {
  BroadPhase bp{{.threads = 2}};
  std::vector<Handle> h;
  Built() {
    std::mt19937 rng(5);
    std::vector<Aabb> boxes;
    for (int i = 0; i < 60; ++i) boxes.push_back(hbp::test::random_box(rng, 8));
    h = bp.add(boxes);
    const std::vector<Handle> statics = bp.add(std::span<const Aabb>(boxes).first(20), {.is_static = true, .layer = 2});
    h.insert(h.end(), statics.begin(), statics.end());
    bp.set_collides(0, 1, false);
    bp.update();
    bp.remove(std::vector<Handle>{h[3], h[7], h[61]});
    bp.set_static(std::vector<Handle>{h[10], h[11]}, true);
    bp.set_layer(std::vector<Handle>{h[12]}, 1);
    bp.update();
    bp.move(std::vector<Handle>{h[20]}, std::vector<Aabb>{{{1, 1, 1}, {2, 2, 2}}});  // pending
  }
};

// Section `tag`'s payload offset and length in a snapshot.
std::pair<std::size_t, std::size_t> find_section(const Bytes& b, const char* tag) {
  std::size_t at = 32;
  while (at + 16 <= b.size()) {
    std::uint64_t length;
    std::memcpy(&length, b.data() + at + 8, 8);
    if (std::memcmp(b.data() + at, tag, 4) == 0) return {at + 16, static_cast<std::size_t>(length)};
    at += 16 + static_cast<std::size_t>(length);
  }
  ADD_FAILURE() << "no section " << tag;
  return {0, 0};
}

// The header's size and checksum made right again after an edit.
void reseal(Bytes& b) {
  const std::uint64_t size = b.size();
  std::memcpy(b.data() + 16, &size, 8);
  const std::uint64_t sum = hbp::detail::xxh64(b.data() + 32, b.size() - 32);
  std::memcpy(b.data() + 24, &sum, 8);
}

template <class T>
void poke(Bytes& b, std::size_t at, T v) {
  std::memcpy(b.data() + at, &v, sizeof v);
}

// Restoring `bad` throws InvalidInput containing `what` and leaves the
// object as it was (its snapshot, and its next update against a twin's).
void expect_rejected(const Bytes& bad, const std::string& what) {
  Built target, twin;
  const Bytes before = target.bp.snapshot();
  try {
    target.bp.restore(bad);
    ADD_FAILURE() << "accepted; expected: " << what;
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("BroadPhase::restore: ", 0), 0u) << e.what();
  }
  EXPECT_TRUE(target.bp.snapshot() == before);
  const hbp::BroadPhaseUpdate& u = target.bp.update();
  const hbp::BroadPhaseUpdate& w = twin.bp.update();
  EXPECT_EQ(u.pairs, w.pairs);
  EXPECT_EQ(u.created, w.created);
  EXPECT_EQ(u.removed, w.removed);
  EXPECT_THROW(BroadPhase::from_snapshot(bad), hbp::InvalidInput);
}

TEST(BroadPhaseSnapshot, TruncatedDataIsRejected) {
  Built w;
  const Bytes snap = w.bp.snapshot();
  std::vector<std::size_t> lengths = {0, 1, 7, 8, 12, 31, 32, 33, 47, 48, snap.size() / 2, snap.size() - 1};
  std::mt19937 rng(3);
  for (int i = 0; i < 20; ++i) lengths.push_back(rng() % snap.size());
  for (const std::size_t n : lengths) {
    SCOPED_TRACE(n);
    const Bytes cut(snap.begin(), snap.begin() + static_cast<std::ptrdiff_t>(n));
    expect_rejected(cut, n < 8 ? "not a BroadPhase snapshot" : n < 32 ? "header: truncated" : "truncated");
  }
  Bytes longer = snap;
  longer.push_back(std::byte{0});
  expect_rejected(longer, "1 bytes after the end");
}

TEST(BroadPhaseSnapshot, CorruptedDataIsRejected) {
  Built w;
  const Bytes snap = w.bp.snapshot();
  std::mt19937 rng(4);
  for (int i = 0; i < 30; ++i) {  // any flipped bit after the header: the checksum
    Bytes bad = snap;
    const std::size_t at = 32 + rng() % (snap.size() - 32);
    bad[at] ^= std::byte{static_cast<unsigned char>(1u << (rng() % 8))};
    SCOPED_TRACE(at);
    expect_rejected(bad, "checksum mismatch");
  }
  Bytes bad = snap;
  bad[0] = std::byte{'X'};
  expect_rejected(bad, "not a BroadPhase snapshot");
  bad = snap;
  poke<std::uint32_t>(bad, 8, 2);
  expect_rejected(bad, "snapshot version 2, this library reads version 1");
  bad = snap;
  poke<std::uint32_t>(bad, 12, 1);
  expect_rejected(bad, "header flags");
  bad = snap;
  bad[24] ^= std::byte{1};
  expect_rejected(bad, "checksum mismatch");
}

// Inconsistent fields under a valid checksum: each named.
TEST(BroadPhaseSnapshot, InconsistentFieldsAreRejected) {
  Built w;
  const Bytes snap = w.bp.snapshot();
  const auto edited = [&](const char* tag, const std::function<void(Bytes&, std::size_t, std::size_t)>& edit) {
    Bytes b = snap;
    const auto [at, length] = find_section(b, tag);
    edit(b, at, length);
    reseal(b);
    return b;
  };
  const std::size_t slots = w.h.size();
  expect_rejected(edited("SLOT", [](Bytes& b, std::size_t at, std::size_t) { b[at + 4] = std::byte{7}; }),
                  "section 'SLOT': slot 0: kind 7");
  expect_rejected(
      edited("SLOT", [&](Bytes& b, std::size_t at, std::size_t) { b[at + 4 + 2 * slots + 5] = std::byte{40}; }),
      "slot 5: layer 40 out of range");
  expect_rejected(edited("SLOT", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at, 1u << 30); }),
                  "slots, more than");
  // Slot 3 was freed: mark it live, and the free list disagrees.
  expect_rejected(edited("SLOT", [](Bytes& b, std::size_t at, std::size_t) { b[at + 4 + 3] = std::byte{1}; }),
                  "section 'FREE': entry");
  expect_rejected(edited("FREE", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at + 4, 0); }),
                  "slot 0 holds a live object");
  expect_rejected(edited("FREE", [](Bytes& b, std::size_t at, std::size_t) {
                    std::uint32_t first;
                    std::memcpy(&first, b.data() + at + 4, 4);
                    poke<std::uint32_t>(b, at + 8, first);
                  }),
                  "listed twice");
  expect_rejected(edited("BOXS", [](Bytes& b, std::size_t at, std::size_t) {
                    poke<float>(b, at + 4, std::numeric_limits<float>::quiet_NaN());
                  }),
                  "section 'BOXS': slot 0:");
  expect_rejected(edited("BOXS", [](Bytes& b, std::size_t at, std::size_t) { poke<float>(b, at + 4, 1e30f); }),
                  "section 'BOXS': slot 0:");
  expect_rejected(edited("LAYR", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at + 4, 0xFFFFFFFFu); }),
                  "layers 0 and 1 collide one way only");
  expect_rejected(edited("PAIR", [](Bytes& b, std::size_t at, std::size_t) {
                    std::uint64_t tmp[2];
                    std::memcpy(tmp, b.data() + at + 24, 16);
                    std::swap(tmp[0], tmp[1]);
                    std::memcpy(b.data() + at + 24, tmp, 16);
                  }),
                  "pairs row 1");
  expect_rejected(edited("PAIR", [](Bytes& b, std::size_t at, std::size_t) {
                    poke<std::uint32_t>(b, at + 24, 5);
                    poke<std::uint32_t>(b, at + 28, 5);
                  }),
                  "pairs row 0 (5, 5): not a < b");
  expect_rejected(edited("STAT", [](Bytes& b, std::size_t at, std::size_t) {
                    poke<double>(b, at + 16, -1.0);
                  }),
                  "wall_ms");
  expect_rejected(edited("EDIT", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at + 16, 3); }),
                  "section 'EDIT': counted row 0: slot 3 holds no live object");
  expect_rejected(edited("EDIT", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at + 8, 1000); }),
                  "section 'EDIT': truncated");
  // Counts far past the data: refused before anything is sized by them.
  expect_rejected(edited("EDIT", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at + 8, 0xFFFFFFFFu); }),
                  "section 'EDIT': truncated");
  expect_rejected(edited("FREE", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at, 0xFFFFFFFFu); }),
                  "section 'FREE': truncated");
  expect_rejected(edited("PAIR", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint64_t>(b, at, 1ull << 39); }),
                  "section 'PAIR': truncated");
  expect_rejected(edited("STAT", [](Bytes& b, std::size_t at, std::size_t) { std::memcpy(b.data() + at - 16, "ZZZZ", 4); }),
                  "section 'ZZZZ' is required but unknown");
  expect_rejected(edited("STAT", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint32_t>(b, at - 12, 6); }),
                  "unknown flags");
  expect_rejected(edited("STAT", [](Bytes& b, std::size_t at, std::size_t) { poke<std::uint64_t>(b, at - 8, 1u << 30); }),
                  "truncated: section 'STAT'");
  // A section twice.
  Bytes twice = snap;
  const auto [at, length] = find_section(snap, "LAYR");
  twice.insert(twice.end(), snap.begin() + static_cast<std::ptrdiff_t>(at - 16),
               snap.begin() + static_cast<std::ptrdiff_t>(at + length));
  reseal(twice);
  expect_rejected(twice, "section 'LAYR' appears twice");
  // A section missing.
  Bytes missing(snap.begin(), snap.begin() + static_cast<std::ptrdiff_t>(at - 16));
  missing.insert(missing.end(), snap.begin() + static_cast<std::ptrdiff_t>(at + length), snap.end());
  reseal(missing);
  expect_rejected(missing, "no 'LAYR' section");
}

// A later version's optional section is skipped: the state is the same.
TEST(BroadPhaseSnapshot, UnknownOptionalSectionsAreSkipped) {
  Built w;
  const Bytes snap = w.bp.snapshot();
  Bytes later = snap;
  const char extra[16 + 5] = {'U', 'S', 'E', 'R', 1, 0, 0, 0, 5, 0, 0, 0, 0, 0, 0, 0, 'h', 'e', 'l', 'l', 'o'};
  later.insert(later.begin() + 32, reinterpret_cast<const std::byte*>(extra),
               reinterpret_cast<const std::byte*>(extra) + sizeof extra);
  reseal(later);
  const BroadPhase r = BroadPhase::from_snapshot(later);
  EXPECT_TRUE(r.snapshot() == snap);
}

TEST(BroadPhaseSnapshot, AddAfterRestoreGivesTheSameHandles) {
  Built w;
  w.bp.remove(std::vector<Handle>{w.h[30], w.h[2], w.h[50]});  // free list order: 3, 7, 61, 30, 2, 50
  const Bytes snap = w.bp.snapshot();
  BroadPhase r = BroadPhase::from_snapshot(snap);
  const std::vector<Aabb> boxes(9, Aabb{{0, 0, 0}, {1, 1, 1}});
  const std::vector<Handle> a = w.bp.add(boxes), b = r.add(boxes);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a[0] & 0xFFFFFFu, w.h[50] & 0xFFFFFFu);  // the last freed slot first
  EXPECT_EQ(w.bp.update().created, r.update().created);
  for (const Handle old : {w.h[30], w.h[2], w.h[50]}) EXPECT_FALSE(r.contains(old));
}

// The pair filter is not part of a snapshot: restore() keeps the object's
// own, and the next update applies it to the stored pairs' successors.
TEST(BroadPhaseSnapshot, RestoreKeepsTheCurrentFilter) {
  BroadPhase a;
  const std::vector<Handle> h = a.add(std::vector<Aabb>{{{0, 0, 0}, {1, 1, 1}}, {{0.5f, 0, 0}, {1.5f, 1, 1}}});
  ASSERT_EQ(a.update().pairs, (std::vector<Pair>{{h[0], h[1]}}));
  const Bytes snap = a.snapshot();
  BroadPhase b;
  b.set_pair_filter([](Handle, Handle) { return false; });
  b.restore(snap);
  EXPECT_EQ(b.last_update().pairs, (std::vector<Pair>{{h[0], h[1]}}));
  const hbp::BroadPhaseUpdate& u = b.update();
  EXPECT_TRUE(u.pairs.empty());
  EXPECT_EQ(u.removed, (std::vector<Pair>{{h[0], h[1]}}));
}

TEST(BroadPhaseSnapshot, BufferFormAndEmptyWorld) {
  Built w;
  const Bytes snap = w.bp.snapshot();
  ASSERT_EQ(w.bp.snapshot_size(), snap.size());
  Bytes buffer(snap.size() + 10, std::byte{0xAB});
  EXPECT_EQ(w.bp.snapshot(buffer), snap.size());
  EXPECT_TRUE(std::equal(snap.begin(), snap.end(), buffer.begin()));
  EXPECT_EQ(buffer.back(), std::byte{0xAB});
  Bytes small(snap.size() - 1, std::byte{0xAB});
  EXPECT_THROW(w.bp.snapshot(small), hbp::CapacityExceeded);
  EXPECT_EQ(std::count(small.begin(), small.end(), std::byte{0xAB}), static_cast<std::ptrdiff_t>(small.size()));

  const BroadPhase empty;
  const Bytes e = empty.snapshot();
  BroadPhase r = BroadPhase::from_snapshot(e, {.threads = 1});
  EXPECT_EQ(r.size(), 0u);
  EXPECT_EQ(r.options().threads, 1u);
  EXPECT_TRUE(r.snapshot() == e);
  EXPECT_TRUE(r.update().pairs.empty());
  w.bp.restore(e);  // a full world emptied by a restore
  EXPECT_EQ(w.bp.size(), 0u);
  EXPECT_TRUE(w.bp.update().pairs.empty());
}

// The checksum is XXH64 (seed 0): the published test values (the low 32
// bits of the third as zstd's frame checksum of the same bytes gives them).
TEST(BroadPhaseSnapshot, ChecksumIsXxh64) {
  EXPECT_EQ(hbp::detail::xxh64("", 0), 0xEF46DB3751D8E999ull);
  EXPECT_EQ(hbp::detail::xxh64("abc", 3), 0x44BC2CF5AD770999ull);
  unsigned char buf[103];
  for (int i = 0; i < 103; ++i) buf[i] = static_cast<unsigned char>((i * 7 + 3) & 255);
  EXPECT_EQ(hbp::detail::xxh64(buf, sizeof buf) & 0xFFFFFFFFu, 0x796DFBC9u);
}

}  // namespace
