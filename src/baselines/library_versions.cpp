// SPDX-License-Identifier: MIT
// Versions of the libraries this binary was compiled against.
#include <CGAL/version.h>

#include "hbp/baselines/baseline.hpp"
#include "hbp/bullet/bullet_headers.hpp"

namespace hbp::baselines {

std::vector<std::pair<std::string, std::string>> baseline_library_versions() {
  const int bt = btGetVersion();
  std::string bullet = std::to_string(bt / 100) + "." + std::to_string(bt % 100);
  bullet += sizeof(btScalar) == sizeof(float) ? " (single precision)" : " (double precision)";
  return {{"Bullet", bullet}, {"CGAL", CGAL_VERSION_STR}, {"FCL", fcl_version()}, {"ODE", ode_version()}};
}

}  // namespace hbp::baselines
