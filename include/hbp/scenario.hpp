// SPDX-License-Identifier: MIT
#pragma once
// The paper's benchmark scenario (section 5; the "framework for benchmarking
// collision detection") and other scenario kinds for robustness and research.
// Deterministic: the same parameters give bit-identical boxes on every run and
// every thread count (own RNG, per-object arithmetic, no fp contraction).
#include <cstdint>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/limits.hpp"
#include "hbp/shape.hpp"

namespace hbp {

enum class ScenarioKind {
  Paper,       // uniform in a cube of side cbrt(50^3 * 5n)
  Clustered,   // Gaussian clusters
  Flat,        // every object centred on the plane z = side / 2
  Huge,        // paper scene plus a few objects spanning most of the world
  Degenerate,  // zero-size boxes, exact face contacts, identical boxes
};
const char* scenario_kind_name(ScenarioKind kind);
ScenarioKind parse_scenario_kind(const std::string& name);  // throws InvalidInput

struct ScenarioParams {
  ScenarioKind kind = ScenarioKind::Paper;
  std::uint32_t n = 1000;
  std::uint32_t frames = 1000;     // paper: 1000 collision-detection cycles
  std::uint32_t variants = 20;     // paper: 20; variant v uses seed v
  std::uint64_t seed = 0;
  double dt = 1.0 / 60.0;          // our choice; the paper does not state it
  double size_min = 25.0;          // per axis, metres
  double size_max = 75.0;
  double linear_speed = 25.0;      // velocity uniform in [-v, v] per axis
  double angular_speed = 2.5;      // rad/s, uniform in [-w, w] per axis
  double volume_per_object = 50.0 * 50.0 * 50.0 * 5.0;  // side = cbrt(this * n)
  std::uint32_t clusters = 8;      // Clustered: number of Gaussian clusters
  double cluster_sigma = 0.05;     // Clustered: sigma as a fraction of the side
  std::uint32_t huge_objects = 4;  // Huge: objects spanning most of the world

  double world_side() const;
};

// Most objects a scenario generates: kMaxScenarioObjects (hbp/limits.hpp);
// a larger n is refused with InvalidInput naming n and the limit.

class Scenario {
 public:
  // Validates the parameters first: InvalidInput naming the bad one (n past
  // kMaxScenarioObjects, NaN/Inf or negative sizes, speeds, dt, volume,
  // cluster sigma, more huge objects than objects, a world too large for
  // float coordinates).
  explicit Scenario(const ScenarioParams& params);

  const ScenarioParams& params() const { return params_; }
  std::uint32_t frame() const { return frame_; }
  std::size_t size() const { return shapes_.size(); }
  const std::vector<Shape>& shapes() const { return shapes_; }
  Aabb world_bounds() const;

  // Advances one time step: integrate, reflect centres off the cube's walls.
  void step();
  // Tight AABBs of the current state (parallel, deterministic).
  void compute_boxes(BoxArray& out) const;

 private:
  ScenarioParams params_;
  double side_ = 0;
  std::uint32_t frame_ = 0;
  std::vector<Shape> shapes_;
  std::vector<Vec3> linear_velocity_;
  std::vector<Vec3> angular_velocity_;
};

}  // namespace hbp
