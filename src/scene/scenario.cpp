// SPDX-License-Identifier: MIT
#include "hbp/scenario.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <sstream>
#include <cmath>

#include "hbp/error.hpp"
#include "support/random.hpp"

namespace hbp {

const char* scenario_kind_name(ScenarioKind kind) {
  switch (kind) {
    case ScenarioKind::Paper: return "paper";
    case ScenarioKind::Clustered: return "clustered";
    case ScenarioKind::Flat: return "flat";
    case ScenarioKind::Huge: return "huge";
    case ScenarioKind::Degenerate: return "degenerate";
  }
  return "unknown";
}

ScenarioKind parse_scenario_kind(const std::string& name) {
  for (auto k : {ScenarioKind::Paper, ScenarioKind::Clustered, ScenarioKind::Flat, ScenarioKind::Huge,
                 ScenarioKind::Degenerate}) {
    if (name == scenario_kind_name(k)) return k;
  }
  throw InvalidInput("unknown scenario kind '" + name + "' (expected paper, clustered, flat, huge or degenerate)");
}

double ScenarioParams::world_side() const {
  if (kind == ScenarioKind::Degenerate) {
    // An integer side keeps every coordinate exactly representable.
    return std::max(8.0, std::ceil(std::cbrt(8.0 * std::max<std::uint32_t>(n, 1))) * 2.0);
  }
  return std::cbrt(volume_per_object * std::max<std::uint32_t>(n, 1));
}

namespace {

Quat random_orientation(Random& rng) {
  // Shoemake's uniform random rotation.
  const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const double t2 = 6.283185307179586 * u2, t3 = 6.283185307179586 * u3;
  return normalized({b * std::cos(t3), a * std::sin(t2), a * std::cos(t2), b * std::sin(t3)});
}

// A double as a user would type it (std::to_string prints 1e100 in full).
std::string number(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

void validate(const ScenarioParams& p) {
  auto bad = [](const std::string& what) { throw InvalidInput("scenario: " + what); };
  if (!(p.dt > 0) || !std::isfinite(p.dt)) bad("dt must be positive and finite");
  if (!(p.size_min >= 0) || !(p.size_max >= p.size_min) || !std::isfinite(p.size_max))
    bad("sizes must satisfy 0 <= size_min <= size_max");
  if (!(p.linear_speed >= 0) || !std::isfinite(p.linear_speed)) bad("linear speed must be >= 0");
  if (!(p.angular_speed >= 0) || !std::isfinite(p.angular_speed)) bad("angular speed must be >= 0");
  if (!(p.volume_per_object > 0) || !std::isfinite(p.volume_per_object)) bad("volume per object must be > 0");
  if (p.kind == ScenarioKind::Clustered && p.clusters == 0) bad("clustered scenes need at least one cluster");
  if (p.n > kMaxScenarioObjects)
    bad("n = " + std::to_string(p.n) + " objects is more than the limit of " + std::to_string(kMaxScenarioObjects) +
        " (kMaxScenarioObjects: ~184 bytes of scenario state per object)");
  if (!(p.cluster_sigma > 0) || !std::isfinite(p.cluster_sigma))
    bad("cluster sigma must be positive and finite (got " + number(p.cluster_sigma) + ")");
  if (p.kind == ScenarioKind::Huge && p.huge_objects > p.n)
    bad("huge objects (" + std::to_string(p.huge_objects) + ") must not outnumber the objects (n = " +
        std::to_string(p.n) + ")");
  // Boxes are float32: the world and the objects must fit with room to spare.
  constexpr double kMaxCoordinate = 1e30;
  if (!(p.world_side() + p.size_max < kMaxCoordinate))
    bad("world side " + number(p.world_side()) + " plus object size " + number(p.size_max) +
        " exceeds 1e30 (float32 coordinates)");
}

}  // namespace

Scenario::Scenario(const ScenarioParams& params) : params_(params) {
  validate(params_);
  side_ = params_.world_side();
  const std::uint32_t n = params_.n;
  shapes_.resize(n);
  linear_velocity_.resize(n);
  angular_velocity_.resize(n);
  Random rng(params_.seed);
  const double v = params_.linear_speed, w = params_.angular_speed;

  std::vector<Vec3> cluster_centres;
  if (params_.kind == ScenarioKind::Clustered) {
    for (std::uint32_t c = 0; c < params_.clusters; ++c)
      cluster_centres.push_back({rng.uniform(0, side_), rng.uniform(0, side_), rng.uniform(0, side_)});
  }

  for (std::uint32_t i = 0; i < n; ++i) {
    Shape& s = shapes_[i];
    Vec3& lv = linear_velocity_[i];
    Vec3& av = angular_velocity_[i];
    if (params_.kind == ScenarioKind::Degenerate) {
      // Thirds: unit cubes on a lattice with exactly touching faces; zero-size
      // boxes on lattice points; stacks of identical boxes. Identity
      // orientation and integer coordinates keep every AABB exact.
      s.kind = ShapeKind::Cuboid;
      const auto cells = static_cast<std::uint32_t>(side_ / 2);
      const std::uint32_t which = i % 3;
      const std::uint32_t cell = rng.below(cells * cells * cells);
      const double cx = 1 + 2.0 * (cell % cells), cy = 1 + 2.0 * ((cell / cells) % cells),
                   cz = 1 + 2.0 * (cell / cells / cells);
      if (which == 0) {
        s.size = {2, 2, 2};
        s.position = {cx, cy, cz};
      } else if (which == 1) {
        s.size = {0, 0, 0};
        s.position = {cx - 1, cy - 1, cz + 1};
      } else {
        s.size = {4, 4, 4};
        s.position = {2.0 * (1 + rng.below(2)), 2.0 * (1 + rng.below(2)), 2.0 * (1 + rng.below(2))};
      }
      // Displacements per frame are multiples of 0.25 m (exact in float).
      lv = {0.25 * static_cast<double>(static_cast<int>(rng.below(5)) - 2), 0, 0};
      av = {0, 0, 0};
      continue;
    }
    s.kind = static_cast<ShapeKind>(rng.below(kShapeKindCount));
    s.size = {rng.uniform(params_.size_min, params_.size_max), rng.uniform(params_.size_min, params_.size_max),
              rng.uniform(params_.size_min, params_.size_max)};
    if (params_.kind == ScenarioKind::Clustered) {
      const Vec3& c = cluster_centres[rng.below(params_.clusters)];
      const double sigma = params_.cluster_sigma * side_;
      auto clamp = [&](double x) { return std::clamp(x, 0.0, side_); };
      s.position = {clamp(c.x + sigma * rng.gaussian()), clamp(c.y + sigma * rng.gaussian()),
                    clamp(c.z + sigma * rng.gaussian())};
    } else {
      s.position = {rng.uniform(0, side_), rng.uniform(0, side_), rng.uniform(0, side_)};
    }
    s.orientation = random_orientation(rng);
    lv = {rng.uniform(-v, v), rng.uniform(-v, v), rng.uniform(-v, v)};
    av = {rng.uniform(-w, w), rng.uniform(-w, w), rng.uniform(-w, w)};
    if (params_.kind == ScenarioKind::Flat) {
      s.position.z = 0.5 * side_;
      lv.z = 0;
    }
    if (params_.kind == ScenarioKind::Huge && i < params_.huge_objects) {
      s.kind = ShapeKind::Cuboid;
      s.size = {rng.uniform(0.5, 0.9) * side_, rng.uniform(0.5, 0.9) * side_, rng.uniform(0.5, 0.9) * side_};
    }
  }
}

Aabb Scenario::world_bounds() const {
  const auto s = static_cast<float>(side_);
  return {{0, 0, 0}, {s, s, s}};
}

void Scenario::step() {
  const double dt = params_.kind == ScenarioKind::Degenerate ? 1.0 : params_.dt;
  const bool rotate = params_.kind != ScenarioKind::Degenerate;
  const double side = side_;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, shapes_.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      Shape& s = shapes_[i];
      Vec3& v = linear_velocity_[i];
      double* pos[3] = {&s.position.x, &s.position.y, &s.position.z};
      double* vel[3] = {&v.x, &v.y, &v.z};
      for (int k = 0; k < 3; ++k) {
        double p = *pos[k] + *vel[k] * dt;
        // Centres reflect off the walls (elastic, velocity mirrored).
        if (p < 0) {
          p = -p;
          *vel[k] = -*vel[k];
        } else if (p > side) {
          p = 2 * side - p;
          *vel[k] = -*vel[k];
        }
        *pos[k] = std::clamp(p, 0.0, side);
      }
      if (rotate) s.orientation = integrate_rotation(s.orientation, angular_velocity_[i], dt);
    }
  });
  ++frame_;
}

void Scenario::compute_boxes(BoxArray& out) const {
  out.resize(shapes_.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, shapes_.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) out.set(i, tight_aabb(shapes_[i]));
  });
}

}  // namespace hbp
