#pragma once
// Pairs a library hands to a callback during its collide() call (FCL's
// broad-phase managers, ODE's spaces): collected raw inside the timed frame,
// filtered with the closed-interval test, sorted and made canonical on
// demand outside it, like Bullet's pair cache.
#include <cstdint>
#include <vector>

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

// The first frame's bounds grown by a quarter of their extent per side (at
// least 1): the world a grid or tree is sized for when the user gives none.
Aabb grown_bounds(const BoxArray& boxes);

// The mean of the boxes' largest extents: a grid cell size a user would pick
// for objects of this size.
double mean_largest_extent(const BoxArray& boxes);

}  // namespace hbp::baselines
