#include "baselines/baseline.hpp"

#include "hbp/error.hpp"

namespace hbp::baselines {

std::vector<std::string> baseline_names() {
  return {"bullet-dbvt", "bullet-dbvt-deferred", "bullet-axis-sweep", "cgal", "brute"};
}

std::unique_ptr<Baseline> make_baseline(const std::string& name, const BaselineOptions& options) {
  if (name == "bullet-dbvt") return make_bullet_dbvt(false);
  if (name == "bullet-dbvt-deferred") return make_bullet_dbvt(true);
  if (name == "bullet-axis-sweep") return make_bullet_axis_sweep(options);
  if (name == "cgal") return make_cgal_box_intersection();
  if (name == "brute") return make_brute_force_baseline();
  std::string known;
  for (const auto& n : baseline_names()) known += (known.empty() ? "" : ", ") + n;
  throw InvalidInput("unknown baseline '" + name + "' (known: " + known + ")");
}

}  // namespace hbp::baselines
