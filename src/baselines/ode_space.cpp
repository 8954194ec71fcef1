// SPDX-License-Identifier: MIT
// ODE's collision spaces: the multi-resolution hash space, the sweep-and-prune
// space and the quadtree space, run as ODE's users run them: geoms created
// and added to a space once, then each frame every geom moved
// (dGeomSetPosition) and dSpaceCollide() calling back for each pair whose
// AABBs overlap (ODE's test is closed: touching boxes are reported).
//
// Each geom is of a user class (dCreateGeomClass) whose AABB function returns
// the object's box of the frame, kept in the geom's class data: ODE sees our
// float boxes exactly (in double), as with a box geom but without the
// rounding of centre +- half extent. Moving the geom marks it dirty, so the
// space recomputes its AABB like any moved geom's.
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <vector>

#include "hbp/baselines/baseline.hpp"
#include "baselines/reported_pairs.hpp"
#include "hbp/error.hpp"

namespace hbp::baselines {
namespace {

struct GeomBox {
  dReal aabb[6];  // ODE's order: min x, max x, min y, max y, min z, max z
};

void geom_aabb(dGeomID g, dReal aabb[6]) {
  const auto* box = static_cast<const GeomBox*>(dGeomGetClassData(g));
  for (int k = 0; k < 6; ++k) aabb[k] = box->aabb[k];
}

dColliderFn* no_collider(int) { return nullptr; }

// ODE is initialised once per process and its per-thread data allocated in
// each thread that touches a space; the user class is registered once
// (ODE allows only a few).
int box_class() {
  static int cls = [] {
    dInitODE2(0);
    dGeomClass c{};
    c.bytes = sizeof(GeomBox);
    c.collider = no_collider;
    c.aabb = geom_aabb;
    return dCreateGeomClass(&c);
  }();
  thread_local bool thread_ready = [] { return dAllocateODEDataForThread(dAllocateMaskAll) != 0; }();
  if (!thread_ready) throw Error("ODE: dAllocateODEDataForThread failed");
  return cls;
}

void set_box(dGeomID g, const BoxArray& boxes, std::size_t i) {
  auto* box = static_cast<GeomBox*>(dGeomGetClassData(g));
  for (int k = 0; k < 3; ++k) {
    box->aabb[2 * k] = boxes.min(k)[i];
    box->aabb[2 * k + 1] = boxes.max(k)[i];
  }
}

// The geom's position (its box's centre): what a user sets each frame, and
// what tells ODE the geom moved.
void move(dGeomID g, const BoxArray& boxes, std::size_t i) {
  const auto c = [&](int k) { return 0.5 * (dReal(boxes.min(k)[i]) + dReal(boxes.max(k)[i])); };
  dGeomSetPosition(g, c(0), c(1), c(2));
}

void near_callback(void* data, dGeomID a, dGeomID b) {
  const auto ia = static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(dGeomGetData(a)));
  const auto ib = static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(dGeomGetData(b)));
  static_cast<ReportedPairs*>(data)->add(ia, ib);
}

enum class OdeSpace { Hash, SweepAndPrune, QuadTree };

int floor_log2(double x) { return static_cast<int>(std::floor(std::log2(x))); }
int ceil_log2(double x) { return static_cast<int>(std::ceil(std::log2(x))); }

// Registry name and table label of each space.
struct OdeNames {
  const char* name;
  const char* label;
};
OdeNames ode_names(OdeSpace kind) {
  switch (kind) {
    case OdeSpace::Hash: return {"ode-hash", "ODE hash space"};
    case OdeSpace::SweepAndPrune: return {"ode-sap", "ODE SAP space"};
    case OdeSpace::QuadTree: return {"ode-quadtree", "ODE quadtree"};
  }
  return {"ode", "ODE"};
}

class OdeSpaceBaseline final : public ReportingBaseline {
 public:
  OdeSpaceBaseline(OdeSpace kind, const BaselineOptions& options)
      : ReportingBaseline(ode_names(kind).name, ode_names(kind).label), kind_(kind), options_(options) {}
  ~OdeSpaceBaseline() override { release(); }

  void setup(const BoxArray& boxes) override {
    release();
    const int cls = box_class();
    space_ = make_space(boxes);
    // The space destroys its geoms with itself (one call, not n).
    dSpaceSetCleanup(space_, 1);
    const auto n = static_cast<std::uint32_t>(boxes.size());
    geoms_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      dGeomID g = dCreateGeom(cls);
      dGeomSetData(g, reinterpret_cast<void*>(static_cast<std::uintptr_t>(i)));
      set_box(g, boxes, i);
      move(g, boxes, i);
      dSpaceAdd(space_, g);
      geoms_[i] = g;
    }
    collide(boxes);
  }

  std::size_t object_count() const override { return geoms_.size(); }

  void move_objects(const BoxArray& boxes) override {
    for (std::size_t i = 0; i < geoms_.size(); ++i) {
      set_box(geoms_[i], boxes, i);
      move(geoms_[i], boxes, i);
    }
  }

  void collide(const BoxArray& boxes) override {
    pairs_.begin(boxes);
    dSpaceCollide(space_, &pairs_, near_callback);
  }

 private:
  dSpaceID make_space(const BoxArray& boxes) const {
    switch (kind_) {
      case OdeSpace::Hash: {
        // Cells from the smallest to the largest object (ODE's default,
        // 2^-3 ... 2^10, would put objects beyond 1024 into its list of
        // big boxes tested against everything): what a user sizes them to.
        dSpaceID s = dHashSpaceCreate(nullptr);
        double lo = HUGE_VAL, hi = 0;
        for (std::size_t i = 0; i < boxes.size(); ++i) {
          float e = 0;
          for (int k = 0; k < 3; ++k) e = std::max(e, boxes.max(k)[i] - boxes.min(k)[i]);
          if (e > 0) lo = std::min(lo, double(e));
          hi = std::max(hi, double(e));
        }
        if (hi <= 0) lo = hi = 1;
        dHashSpaceSetLevels(s, std::max(-20, floor_log2(lo)), std::min(40, std::max(floor_log2(lo), ceil_log2(hi))));
        return s;
      }
      case OdeSpace::SweepAndPrune: return dSweepAndPruneSpaceCreate(nullptr, dSAP_AXES_XYZ);
      case OdeSpace::QuadTree: {
        // ODE's quadtree divides two axes (x, y here: ODE's default up
        // axis is z). Depth: leaf blocks about as large as twice an object,
        // at most 8 levels (4^8 leaves), as ODE's own demos size it.
        Aabb w = options_.world;
        if (!(w.min[0] <= w.max[0] && w.min[1] <= w.max[1] && w.min[2] <= w.max[2])) w = grown_bounds(boxes);
        const dVector3 centre = {0.5 * (dReal(w.min[0]) + w.max[0]), 0.5 * (dReal(w.min[1]) + w.max[1]),
                                 0.5 * (dReal(w.min[2]) + w.max[2]), 0};
        const dVector3 extents = {dReal(w.max[0]) - w.min[0], dReal(w.max[1]) - w.min[1],
                                  dReal(w.max[2]) - w.min[2], 0};
        const double side = std::max(extents[0], extents[1]);
        const int depth = std::clamp(ceil_log2(side / (2 * mean_largest_extent(boxes))) + 1, 1, 8);
        return dQuadTreeSpaceCreate(nullptr, centre, extents, depth);
      }
    }
    throw Error("ode: unknown space");
  }

  void release() {
    if (space_) dSpaceDestroy(space_);
    space_ = nullptr;
    geoms_.clear();
    pairs_.clear();
  }

  OdeSpace kind_;
  BaselineOptions options_;
  dSpaceID space_ = nullptr;
  std::vector<dGeomID> geoms_;
};

}  // namespace

std::unique_ptr<Baseline> make_ode_hash_space() {
  return std::make_unique<OdeSpaceBaseline>(OdeSpace::Hash, BaselineOptions{});
}
std::unique_ptr<Baseline> make_ode_sap_space() {
  return std::make_unique<OdeSpaceBaseline>(OdeSpace::SweepAndPrune, BaselineOptions{});
}
std::unique_ptr<Baseline> make_ode_quadtree_space(const BaselineOptions& options) {
  return std::make_unique<OdeSpaceBaseline>(OdeSpace::QuadTree, options);
}

std::string ode_version() {
  // ODE has no version macro: the build passes pkg-config's (HBP_ODE_VERSION);
  // dGetConfiguration() names the precision and build options.
  const std::string config = dGetConfiguration();
  return std::string(HBP_ODE_VERSION) +
         (config.find("double_precision") != std::string::npos ? " (double precision)" : " (single precision)");
}

}  // namespace hbp::baselines
