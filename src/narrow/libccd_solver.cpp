// SPDX-License-Identifier: MIT
#include "hbp/narrow/libccd_solver.hpp"

#include "hbp/error.hpp"

#if __has_include(<ccd/ccd.h>)
#define HBP_HAVE_LIBCCD 1
#include <ccd/ccd.h>
#else
#define HBP_HAVE_LIBCCD 0
#endif

namespace hbp::narrow {

#if HBP_HAVE_LIBCCD
static_assert(sizeof(ccd_real_t) == sizeof(double), "libccd must be built in double precision");

namespace {

void ccd_support(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* out) {
  const auto* c = static_cast<const Convex*>(obj);
  const V3 p = c->support({dir->v[0], dir->v[1], dir->v[2]});
  ccdVec3Set(out, p.x, p.y, p.z);
}

void ccd_center(const void* obj, ccd_vec3_t* out) {
  const auto* c = static_cast<const Convex*>(obj);
  ccdVec3Set(out, c->centre.x, c->centre.y, c->centre.z);
}

}  // namespace

bool libccd_available() { return true; }

bool libccd_intersect(const Convex& a, const Convex& b, Hit* hit, CcdAlgorithm algorithm) {
  const double scale = pair_scale(a, b);
  ccd_t ccd;
  CCD_INIT(&ccd);
  ccd.support1 = ccd_support;
  ccd.support2 = ccd_support;
  ccd.center1 = ccd_center;
  ccd.center2 = ccd_center;
  ccd.max_iterations = 500;
  ccd.mpr_tolerance = 1e-10 * scale;
  ccd.epa_tolerance = 1e-10 * scale;
  ccd.dist_tolerance = 1e-12 * scale;
  if (!hit) {
    return algorithm == CcdAlgorithm::Mpr ? ccdMPRIntersect(&a, &b, &ccd) != 0 : ccdGJKIntersect(&a, &b, &ccd) != 0;
  }
  ccd_real_t depth = 0;
  ccd_vec3_t dir, pos;
  const int rc = algorithm == CcdAlgorithm::Mpr ? ccdMPRPenetration(&a, &b, &ccd, &depth, &dir, &pos)
                                                : ccdGJKPenetration(&a, &b, &ccd, &depth, &dir, &pos);
  if (rc == -2) throw Error("libccd: out of memory in penetration query");
  if (rc != 0) return false;
  // libccd: translating b by depth * dir separates the shapes.
  V3 n{dir.v[0], dir.v[1], dir.v[2]};
  const double len = norm(n);
  hit->normal = len > 0 ? n * (1.0 / len) : V3{0, 0, 1};
  hit->depth = depth > 0 ? depth : 0;
  hit->point = {pos.v[0], pos.v[1], pos.v[2]};
  return true;
}

#else

bool libccd_available() { return false; }

bool libccd_intersect(const Convex&, const Convex&, Hit*, CcdAlgorithm) {
  throw Error("libccd: hybrid_broadphase was built without libccd (install libccd-dev)");
}

#endif

}  // namespace hbp::narrow
