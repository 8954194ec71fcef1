// SPDX-License-Identifier: MIT
#pragma once
// A brute-force reference of hbp::BroadPhase and a randomized session that
// applies the same edits (add, move, remove, set_static, set_layer,
// set_collides, set_pair_filter) to several broad phases and to the
// reference, then checks every system's update() against it: pairs (every
// pair of live objects, at least one moving, overlapping, layers colliding,
// filter accepting), created/removed as the set differences with the
// previous frame, the stats' counts, and each object's handle, kind, box and
// layer. Shared by the broad-phase, sleeping and snapshot tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "grid_boxes.hpp"
#include "hbp/broad_phase.hpp"
#include "pair_sets.hpp"

namespace hbp::test {

struct RefObject {
  Aabb box;
  bool is_static;
  std::uint8_t layer;
};

inline bool same_box(const Aabb& a, const Aabb& b) {
  for (int k = 0; k < 3; ++k)
    if (a.min[k] != b.min[k] || a.max[k] != b.max[k]) return false;
  return true;
}

struct Reference {
  std::map<Handle, RefObject> objects;
  std::uint32_t mask[kLayerCount];
  BroadPhase::PairFilter filter;
  std::vector<Pair> previous;
  // The objects each stats counter counts since the last update (see
  // BroadPhaseUpdateStats): `moved`: moving objects added, woken or moved to
  // another box; `static_changed`: static objects added, moved to another
  // box or removed, and objects put to sleep or woken.
  std::set<Handle> moved, static_changed;

  Reference() { std::fill(std::begin(mask), std::end(mask), 0xFFFFFFFFu); }

  // BroadPhase::set_collides: layers a and b (either order) collide or not.
  void set_collides(std::uint32_t a, std::uint32_t b, bool c) {
    if (c) {
      mask[a] |= 1u << b;
      mask[b] |= 1u << a;
    } else {
      mask[a] &= ~(1u << b);
      mask[b] &= ~(1u << a);
    }
  }

  std::vector<Pair> pairs() const {
    std::vector<std::pair<Handle, const RefObject*>> v;
    for (const auto& [h, o] : objects) v.emplace_back(h, &o);
    std::vector<Pair> out;
    for (std::size_t i = 0; i < v.size(); ++i)
      for (std::size_t j = i + 1; j < v.size(); ++j) {
        const RefObject& a = *v[i].second;
        const RefObject& b = *v[j].second;
        if (a.is_static && b.is_static) continue;
        if (!overlaps(a.box, b.box)) continue;
        if (!((mask[a.layer] >> b.layer) & 1u)) continue;
        const Pair p{v[i].first, v[j].first};  // map order: a < b
        if (filter && !filter(p.a, p.b)) continue;
        out.push_back(p);
      }
    return out;
  }
};

// One randomized session: every edit goes to each system and the reference.
// Copyable: a copy continues with the same random stream, so two copies
// driving different systems make the same edits.
struct Session {
  std::mt19937 rng;
  float world;
  Reference ref;
  std::vector<BroadPhase*> systems;
  std::vector<Handle> live;
  int frame = 0;
  std::uint64_t pairs_seen = 0, events_seen = 0;

  Session(unsigned seed, float w, std::vector<BroadPhase*> s) : rng(seed), world(w), systems(std::move(s)) {}

  std::size_t below(std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); }

  // Up to n distinct live handles in random order, of one kind (0: moving,
  // 1: static) or of any (-1).
  std::vector<Handle> some(std::size_t n, int kind = -1) {
    std::vector<Handle> h;
    for (const Handle x : live)
      if (kind < 0 || ref.objects[x].is_static == (kind == 1)) h.push_back(x);
    std::shuffle(h.begin(), h.end(), rng);
    h.resize(std::min(n, h.size()));
    return h;
  }

  void add(std::size_t n, bool is_static, std::uint8_t layer) {
    std::vector<Aabb> boxes(n);
    for (Aabb& b : boxes) b = random_box(rng, world);
    std::vector<Handle> h;
    for (BroadPhase* s : systems) {
      const std::vector<Handle> got = s->add(boxes, {.is_static = is_static, .layer = layer});
      if (s == systems.front()) h = got;
      ASSERT_EQ(got, h) << "same edits, same handles (frame " << frame << ")";
    }
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_FALSE(ref.objects.count(h[i])) << "a live handle handed out twice";
      ref.objects[h[i]] = {boxes[i], is_static, layer};
      (is_static ? ref.static_changed : ref.moved).insert(h[i]);
      live.push_back(h[i]);
    }
  }

  // Nudges (mostly), teleports, or moves to the box an object has.
  void move(std::vector<Handle> h) {
    std::vector<Aabb> boxes;
    for (const Handle x : h) {
      const unsigned kind = rng() % 10;
      const Aabb& now = ref.objects[x].box;
      boxes.push_back(kind == 0 ? random_box(rng, world) : kind == 1 ? now : nudged(rng, now));
    }
    for (BroadPhase* s : systems) s->move(h, boxes);
    for (std::size_t i = 0; i < h.size(); ++i) {
      RefObject& o = ref.objects[h[i]];
      if (!same_box(o.box, boxes[i])) (o.is_static ? ref.static_changed : ref.moved).insert(h[i]);
      o.box = boxes[i];
    }
  }

  // Every moving object in handle order: the whole-frame batch when it is
  // the first edit after an update.
  void move_every_moving() {
    std::vector<Handle> h;
    for (const auto& [x, o] : ref.objects)
      if (!o.is_static) h.push_back(x);
    move(h);
  }

  void remove(std::vector<Handle> h) {
    for (BroadPhase* s : systems) s->remove(h);
    for (const Handle x : h) {
      if (ref.objects[x].is_static) ref.static_changed.insert(x);
      ref.objects.erase(x);
      live.erase(std::find(live.begin(), live.end(), x));
    }
  }

  // Objects of either kind in the batch: those already of the kind stay.
  void set_static(const std::vector<Handle>& h, bool is_static) {
    for (BroadPhase* s : systems) s->set_static(h, is_static);
    for (const Handle x : h) {
      RefObject& o = ref.objects[x];
      if (o.is_static == is_static) continue;
      o.is_static = is_static;
      ref.static_changed.insert(x);
      if (!is_static) ref.moved.insert(x);
    }
  }

  void set_layer(const std::vector<Handle>& h, std::uint8_t layer) {
    for (BroadPhase* s : systems) s->set_layer(h, layer);
    for (const Handle x : h) ref.objects[x].layer = layer;
  }

  void set_collides(std::uint32_t a, std::uint32_t b, bool c) {
    for (BroadPhase* s : systems) s->set_collides(a, b, c);
    ref.set_collides(a, b, c);
  }

  void set_filter(BroadPhase::PairFilter f) {
    for (BroadPhase* s : systems) s->set_pair_filter(f);
    ref.filter = std::move(f);
  }

  // One frame's random edits. Half the frames only move objects (the
  // incremental paths); the others mix every kind of edit, sleeping and
  // waking most often. `target` bounds the live objects.
  void random_edits(std::size_t target) {
    const std::size_t n = std::max<std::size_t>(live.size(), 1);
    if (rng() % 4 == 0) move_every_moving();  // first edit of the frame
    if (rng() % 2 == 0) {
      move(some(n / 4 + 1, 0));
      return;
    }
    const int ops = 1 + static_cast<int>(rng() % 4);
    for (int i = 0; i < ops; ++i) {
      switch (rng() % 10) {
        case 0:
        case 1:
          if (live.size() < target) add(1 + below(target / 10 + 1), rng() % 3 == 0, static_cast<std::uint8_t>(rng() % 3));
          break;
        case 2:
          if (live.size() > target / 2) remove(some(1 + below(target / 10 + 1)));
          break;
        case 3:
        case 4:
          set_static(some(1 + below(n / 5 + 1), 0), true);  // moving objects fall asleep
          break;
        case 5:
        case 6:
          set_static(some(1 + below(n / 5 + 1), 1), false);  // static objects wake
          break;
        case 7:
          set_static(some(1 + below(n / 5 + 1)), rng() % 2 == 0);  // a mixed batch
          break;
        case 8:
          if (rng() % 3 == 0)
            set_collides(static_cast<std::uint32_t>(rng() % 3), static_cast<std::uint32_t>(rng() % 3), rng() % 2 == 0);
          else
            set_layer(some(1 + below(n / 8 + 1)), static_cast<std::uint8_t>(rng() % 3));
          break;
        default:
          move(some(n / 3 + 1, rng() % 2 ? 0 : -1));
          break;
      }
      if (testing::Test::HasFatalFailure()) return;
    }
  }

  // Updates every system and checks it against the reference.
  void check_frame() {
    const std::vector<Pair> want = ref.pairs();
    const std::vector<Pair> created = minus(want, ref.previous);
    const std::vector<Pair> removed = minus(ref.previous, want);
    std::uint32_t statics = 0;
    for (const auto& [h, o] : ref.objects) statics += o.is_static;
    for (std::size_t i = 0; i < systems.size(); ++i) {
      BroadPhase& s = *systems[i];
      const BroadPhaseUpdate& u = s.update();
      ASSERT_EQ(u.pairs, want) << "system " << i << " frame " << frame;
      ASSERT_EQ(u.created, created) << "system " << i << " frame " << frame;
      ASSERT_EQ(u.removed, removed) << "system " << i << " frame " << frame;
      ASSERT_EQ(s.size(), ref.objects.size());
      ASSERT_EQ(s.stats().statics, statics) << "system " << i << " frame " << frame;
      ASSERT_EQ(s.stats().moving, ref.objects.size() - statics) << "system " << i << " frame " << frame;
      ASSERT_EQ(s.stats().moved, ref.moved.size()) << "system " << i << " frame " << frame;
      ASSERT_EQ(s.stats().static_changes, ref.static_changed.size()) << "system " << i << " frame " << frame;
    }
    pairs_seen += want.size();
    events_seen += created.size() + removed.size();
    ref.previous = want;
    ref.moved.clear();
    ref.static_changed.clear();
    ++frame;
  }

  // Every live object's handle, kind, box and layer as the reference has them.
  void check_objects() const {
    for (BroadPhase* s : systems)
      for (const auto& [h, o] : ref.objects) {
        ASSERT_TRUE(s->contains(h)) << "handle " << h << " frame " << frame;
        ASSERT_EQ(s->is_static(h), o.is_static) << "handle " << h << " frame " << frame;
        ASSERT_TRUE(same_box(s->box(h), o.box)) << "handle " << h << " frame " << frame;
        ASSERT_EQ(s->layer(h), o.layer) << "handle " << h << " frame " << frame;
      }
  }
};

}  // namespace hbp::test
