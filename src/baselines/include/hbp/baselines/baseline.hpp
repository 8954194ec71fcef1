// SPDX-License-Identifier: MIT
#pragma once
// The systems a user would pick instead of ours (Bullet, CGAL, brute force),
// behind one small interface so the benchmark and the tests drive them alike.
// Not part of the core library: compiled into hbp_baselines for `hbp bench`
// and the tests only.
//
//   auto b = hbp::baselines::make_baseline("bullet-dbvt");
//   b->setup(first_frame);             // untimed: create proxies once
//   for (each frame) {
//     b->update(boxes);                // the timed work a user would do
//     check(b->exact_pairs());         // untimed: filtered, sorted, canonical
//   }
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp::baselines {

struct BaselineOptions {
  // World bounds for quantising sweep and prune (bt32BitAxisSweep3) and for
  // the grids and trees that need them (FCL's spatial hash, ODE's quadtree). Empty
  // (min > max): the first frame's bounds, grown by a quarter of their extent
  // per side. Boxes outside are clamped by Bullet, which keeps overlaps.
  Aabb world{{1, 1, 1}, {0, 0, 0}};
};

class Baseline {
 public:
  virtual ~Baseline() = default;
  // Registry name ("bullet-dbvt") and a table label ("Bullet DBVT").
  virtual std::string name() const = 0;
  virtual std::string label() const = 0;
  // One-time preparation with the first frame (Bullet: create every proxy).
  // Kept out of the per-frame time, as in a game where objects live long.
  // Calling it again starts over with a new world.
  virtual void setup(const BoxArray& boxes) = 0;
  // One frame: the work a user of the library does each frame (Bullet:
  // setAabb on every proxy, then calculateOverlappingPairs). `boxes` must
  // have the size given to setup() and stay alive until exact_pairs().
  virtual void update(const BoxArray& boxes) = 0;
  // Pairs the system reported for the last frame, before filtering (Bullet:
  // its pair cache, a superset built from fattened or quantised boxes).
  virtual std::size_t raw_pairs() const = 0;
  // The exact pair set of the last frame: the raw pairs filtered with the
  // closed-interval test where the system reports a superset, then sorted
  // and canonical. Computed on demand, outside the timed update().
  virtual const std::vector<Pair>& exact_pairs() = 0;
};

// Names: "bullet-dbvt" (Bullet defaults, the paper's CPU baseline),
// "bullet-dbvt-deferred" (m_deferedcollide = true), "bullet-axis-sweep"
// (bt32BitAxisSweep3), "cgal" (box_self_intersection_d), "fcl-dynamic-aabb-tree",
// "fcl-sap", "fcl-interval-tree", "fcl-spatial-hash" (FCL's broad-phase
// managers), "ode-hash", "ode-sap", "ode-quadtree" (ODE's spaces), "brute".
// Throws InvalidInput naming the unknown baseline and listing the known ones.
std::unique_ptr<Baseline> make_baseline(const std::string& name, const BaselineOptions& options = {});
std::vector<std::string> baseline_names();

// Each factory lives in its baseline's own file.
std::unique_ptr<Baseline> make_bullet_dbvt(bool deferred_collide);
std::unique_ptr<Baseline> make_bullet_axis_sweep(const BaselineOptions& options);
std::unique_ptr<Baseline> make_cgal_box_intersection();
std::unique_ptr<Baseline> make_brute_force_baseline();
std::unique_ptr<Baseline> make_fcl_dynamic_aabb_tree();
std::unique_ptr<Baseline> make_fcl_sap();
std::unique_ptr<Baseline> make_fcl_interval_tree();
std::unique_ptr<Baseline> make_fcl_spatial_hash(const BaselineOptions& options);
std::unique_ptr<Baseline> make_ode_hash_space();
std::unique_ptr<Baseline> make_ode_sap_space();
std::unique_ptr<Baseline> make_ode_quadtree_space(const BaselineOptions& options);
std::string fcl_version();
std::string ode_version();

// Versions of the libraries behind the baselines, for reports:
// {{"Bullet", "3.24 (single precision)"}, {"CGAL", "5.5.1"}, {"FCL", "0.7.0"},
// {"ODE", "0.16.2 (double precision)"}}.
std::vector<std::pair<std::string, std::string>> baseline_library_versions();

}  // namespace hbp::baselines
