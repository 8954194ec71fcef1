// SPDX-License-Identifier: MIT
#include "hbp/baselines/baseline.hpp"

#include "hbp/error.hpp"

namespace hbp::baselines {

std::vector<std::string> baseline_names() {
  return {"bullet-dbvt",      "bullet-dbvt-deferred", "bullet-axis-sweep", "cgal",
          "fcl-dynamic-aabb-tree", "fcl-sap",          "fcl-interval-tree", "fcl-spatial-hash",
          "ode-hash",         "ode-sap",              "ode-quadtree",      "brute"};
}

std::unique_ptr<Baseline> make_baseline(const std::string& name, const BaselineOptions& options) {
  if (name == "bullet-dbvt") return make_bullet_dbvt(false);
  if (name == "bullet-dbvt-deferred") return make_bullet_dbvt(true);
  if (name == "bullet-axis-sweep") return make_bullet_axis_sweep(options);
  if (name == "cgal") return make_cgal_box_intersection();
  if (name == "fcl-dynamic-aabb-tree") return make_fcl_dynamic_aabb_tree();
  if (name == "fcl-sap") return make_fcl_sap();
  if (name == "fcl-interval-tree") return make_fcl_interval_tree();
  if (name == "fcl-spatial-hash") return make_fcl_spatial_hash(options);
  if (name == "ode-hash") return make_ode_hash_space();
  if (name == "ode-sap") return make_ode_sap_space();
  if (name == "ode-quadtree") return make_ode_quadtree_space(options);
  if (name == "brute") return make_brute_force_baseline();
  std::string known;
  for (const auto& n : baseline_names()) known += (known.empty() ? "" : ", ") + n;
  throw InvalidInput("unknown baseline '" + name + "' (known: " + known + ")");
}

}  // namespace hbp::baselines
