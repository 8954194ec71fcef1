// SPDX-License-Identifier: MIT
#include "hbp/benchdata/random_pairs.hpp"

#include <cmath>

#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/intersect.hpp"
#include "support/random.hpp"

namespace hbp {

ShapePairGenerator::ShapePairGenerator(std::uint64_t seed, const ShapePairOptions& options)
    : state_(seed), options_(options) {}

double ShapePairGenerator::uniform() {
  // One hbp::Random step per draw, keyed on a running counter (portable).
  Random r(state_++);
  return r.uniform();
}

Shape ShapePairGenerator::random_shape(ShapeKind kind) {
  Shape s;
  s.kind = kind;
  const double lo = options_.size_min, hi = options_.size_max;
  s.size = {lo + (hi - lo) * uniform(), lo + (hi - lo) * uniform(), lo + (hi - lo) * uniform()};
  if (uniform() < options_.circular_fraction) {
    s.size.y = s.size.x;
    if (kind == ShapeKind::Sphere) s.size.z = s.size.x;
  }
  // Uniform rotation (Shoemake's subgroup method).
  const double u1 = uniform(), u2 = 6.283185307179586 * uniform(), u3 = 6.283185307179586 * uniform();
  const double s1 = std::sqrt(1 - u1), s2 = std::sqrt(u1);
  s.orientation = normalized(Quat{s2 * std::cos(u3), s1 * std::sin(u2), s1 * std::cos(u2), s2 * std::sin(u3)});
  const double w = options_.world;
  s.position = {w * (2 * uniform() - 1), w * (2 * uniform() - 1), w * (2 * uniform() - 1)};
  return s;
}

ShapePair ShapePairGenerator::next(ShapeKind ka, ShapeKind kb) {
  ShapePair p;
  p.a = random_shape(ka);
  p.b = random_shape(kb);
  // Random unit direction from a's centre to b's.
  const double z = 2 * uniform() - 1, phi = 6.283185307179586 * uniform();
  const double rho = std::sqrt(std::fmax(0.0, 1 - z * z));
  const Vec3 u{rho * std::cos(phi), rho * std::sin(phi), z};
  const double reach = narrow::make_convex(p.a).radius + narrow::make_convex(p.b).radius;
  auto place = [&](double t) {
    p.b.position = {p.a.position.x + u.x * t, p.a.position.y + u.y * t, p.a.position.z + u.z * t};
  };
  if (uniform() < options_.near_fraction) {
    // Touching offset along u: bisection on the exact test (intersecting at
    // 0, since both centres are interior; separated beyond the bounding reach).
    double lo = 0, hi = reach * 1.001;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      place(mid);
      (intersect(p.a, p.b) ? lo : hi) = mid;
    }
    const double l0 = std::log(options_.near_rel_min), l1 = std::log(options_.near_rel_max);
    double rel = std::exp(l0 + (l1 - l0) * uniform());
    if (uniform() < 0.5) rel = -rel;
    place(0.5 * (lo + hi) * (1 + rel));
    p.near = true;
    p.near_rel = rel;
  } else {
    place(reach * uniform());
  }
  return p;
}

ShapePair ShapePairGenerator::next() {
  const auto ka = static_cast<ShapeKind>(static_cast<int>(uniform() * kShapeKindCount));
  const auto kb = static_cast<ShapeKind>(static_cast<int>(uniform() * kShapeKindCount));
  return next(ka, kb);
}

}  // namespace hbp
