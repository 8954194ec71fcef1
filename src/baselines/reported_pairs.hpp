// SPDX-License-Identifier: MIT
#pragma once
// Pairs a library hands to a callback during its collide() call (FCL's
// broad-phase managers, ODE's spaces): collected raw inside the timed frame,
// filtered with the closed-interval test, sorted and made canonical on
// demand outside it, like Bullet's pair cache.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "hbp/baselines/baseline.hpp"
#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp::baselines {

class ReportedPairs {
 public:
  // A new frame: forget the last one's pairs (keeps the capacity: no
  // allocation per frame once the largest frame has been seen).
  void begin(const BoxArray& boxes) {
    raw_.clear();
    boxes_ = &boxes;
    dirty_ = true;
  }
  void add(std::uint32_t a, std::uint32_t b) { raw_.push_back({a, b}); }
  std::size_t raw_count() const { return raw_.size(); }
  // The raw pairs whose boxes overlap exactly; a pair reported twice counts
  // once (raw_count() still counts it twice).
  const std::vector<Pair>& exact();
  void clear();

 private:
  std::vector<Pair> raw_;
  std::vector<Pair> exact_;
  const BoxArray* boxes_ = nullptr;
  bool dirty_ = false;
};

// The frame of a library that keeps one object per box and reports pairs
// through a callback (FCL's managers, ODE's spaces), written once: check the
// frame has the boxes setup() had, move every object to its box of the frame,
// let the library collide into pairs_. One virtual call per frame per step;
// the per-object loop is the library's own, inside move_objects().
class ReportingBaseline : public Baseline {
 public:
  ReportingBaseline(std::string name, std::string label) : name_(std::move(name)), label_(std::move(label)) {}
  std::string name() const final { return name_; }
  std::string label() const final { return label_; }
  void update(const BoxArray& boxes) final;
  std::size_t raw_pairs() const final { return pairs_.raw_count(); }
  const std::vector<Pair>& exact_pairs() final { return pairs_.exact(); }

 protected:
  // How many objects setup() created.
  virtual std::size_t object_count() const = 0;
  // Every object to its box of the frame (boxes.size() == object_count()).
  virtual void move_objects(const BoxArray& boxes) = 0;
  // The library's collide call, reporting into pairs_ (pairs_.begin first).
  virtual void collide(const BoxArray& boxes) = 0;

  ReportedPairs pairs_;

 private:
  std::string name_, label_;
};

// The boxes' bounds; the unit box [0, 1]^3 when there are none.
Aabb box_bounds(const BoxArray& boxes);

// The first frame's bounds grown by a quarter of their extent per side (at
// least 1): the world a grid or tree is sized for when the user gives none.
Aabb grown_bounds(const BoxArray& boxes);

// The mean of the boxes' largest extents: a grid cell size a user would pick
// for objects of this size.
double mean_largest_extent(const BoxArray& boxes);

}  // namespace hbp::baselines
