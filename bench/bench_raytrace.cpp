// SPDX-License-Identifier: MIT
// The paper's claim (section 3.2) measured: per-frame cost of maintaining the
// two-level hierarchy shared by collision detection and the ray tracer, versus
// maintaining the collision partition plus a separate full-scene BVH (ours,
// and Embree's as the industry reference); and ray throughput (primary and
// shadow rays, million rays/s) on the shared hierarchy versus Embree, same
// scene, same run. Paper scene, n = 100,000 and 1,024,000.
//
//   bench_raytrace --benchmark_filter=Maintain   # per-frame maintenance
//   bench_raytrace --benchmark_filter=Rays       # ray throughput
//
// Embree (Debian libembree-dev) traverses its own BVH over user geometry whose
// intersection callback is the same exact shape test ours uses, so the
// comparison is hierarchy against hierarchy.
#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <ctime>
#include <limits>
#include <map>
#include <memory>
#include <vector>

#include "hbp/kd_partition.hpp"
#include "hbp/raytrace/camera.hpp"
#include "hbp/raytrace/traversal.hpp"
#include "hbp/scenario.hpp"
#include "hbp/two_level_hierarchy.hpp"
#include "hierarchy/cell_bvh.hpp"

#ifdef HBP_HAVE_EMBREE
#include <embree3/rtcore.h>
#endif

namespace {

using namespace hbp;

constexpr std::uint32_t kCellLimit = 1024;  // the software engine's defaults
constexpr float kXSplitWeight = 0.5f;
constexpr std::uint32_t kWarmFrames = 3;
constexpr std::uint32_t kImage = 512;  // primary rays: kImage x kImage

ScenarioParams paper(std::uint32_t n) {
  ScenarioParams p;
  p.n = n;
  return p;
}

// Advances the scene one frame (not timed) and returns its boxes.
struct Frames {
  explicit Frames(std::uint32_t n) : scenario(paper(n)) { scenario.compute_boxes(boxes); }
  const BoxArray& next() {
    scenario.step();
    scenario.compute_boxes(boxes);
    return boxes;
  }
  Scenario scenario;
  BoxArray boxes;
};

template <class Update>
void run_frames(benchmark::State& state, Frames& frames, Update&& update) {
  for (std::uint32_t i = 0; i < kWarmFrames; ++i) update(i == 0 ? frames.boxes : frames.next(), false);
  for (auto _ : state) {
    state.PauseTiming();
    const BoxArray& boxes = frames.next();
    state.ResumeTiming();
    update(boxes, true);
  }
}

// ---- maintenance ------------------------------------------------------------

void BM_Maintain_SharedTwoLevel(benchmark::State& state) {
  Frames frames(static_cast<std::uint32_t>(state.range(0)));
  TwoLevelHierarchy h({.cell_limit = kCellLimit, .x_split_weight = kXSplitWeight});
  double partition_ms = 0, bvh_ms = 0, kept = 0, edited = 0, rebuilt = 0;
  std::uint64_t frames_run = 0;
  run_frames(state, frames, [&](const BoxArray& boxes, bool timed) {
    h.update(boxes);
    if (!timed) return;
    const HierarchyStats& s = h.stats();
    partition_ms += s.partition_ms;
    bvh_ms += s.bvh_ms + s.top_ms;
    kept += s.refitted;
    edited += s.edited;
    rebuilt += s.rebuilt;
    ++frames_run;
  });
  const double f = static_cast<double>(frames_run);
  state.counters["cells"] = h.cell_count();
  state.counters["partition_ms"] = partition_ms / f;
  state.counters["cell_bvhs_ms"] = bvh_ms / f;
  state.counters["refit_cells"] = kept / f;
  state.counters["edited_cells"] = edited / f;
  state.counters["rebuilt_cells"] = rebuilt / f;
}

void BM_Maintain_PartitionOnly(benchmark::State& state) {
  Frames frames(static_cast<std::uint32_t>(state.range(0)));
  KdPartition partition(kCellLimit, kXSplitWeight);
  run_frames(state, frames, [&](const BoxArray& boxes, bool) { partition.update(boxes); });
  state.counters["cells"] = partition.cell_count();
}

// Partition + our full-scene binned-SAH BVH, refitted every frame and rebuilt
// when its SAH cost exceeds 1.4x its cost when built (the per-cell policy).
void BM_Maintain_PartitionPlusOurBvhRefit(benchmark::State& state) {
  Frames frames(static_cast<std::uint32_t>(state.range(0)));
  KdPartition partition(kCellLimit, kXSplitWeight);
  std::vector<BvhNode> nodes;
  bvh::Scratch scratch;
  float built = 0;
  std::uint64_t rebuilds = 0, frames_run = 0;
  run_frames(state, frames, [&](const BoxArray& boxes, bool timed) {
    partition.update(boxes);
    if (nodes.empty() || bvh::refit(boxes, nodes) > 1.4f * built) {
      bvh::build(boxes, nodes, scratch);
      built = bvh::sah_cost(nodes);
      rebuilds += timed ? 1 : 0;
    }
    frames_run += timed ? 1 : 0;
  });
  state.counters["bvh_rebuilds_per_frame"] = static_cast<double>(rebuilds) / static_cast<double>(frames_run);
}

// Partition + our full-scene BVH rebuilt every frame.
void BM_Maintain_PartitionPlusOurBvhRebuild(benchmark::State& state) {
  Frames frames(static_cast<std::uint32_t>(state.range(0)));
  KdPartition partition(kCellLimit, kXSplitWeight);
  std::vector<BvhNode> nodes;
  bvh::Scratch scratch;
  run_frames(state, frames, [&](const BoxArray& boxes, bool) {
    partition.update(boxes);
    bvh::build(boxes, nodes, scratch);
  });
}

#ifdef HBP_HAVE_EMBREE

struct EmbreeUser {
  const BoxArray* boxes = nullptr;
  const std::vector<ShapeGeometry>* geometry = nullptr;
};

void embree_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* u = static_cast<const EmbreeUser*>(args->geometryUserPtr);
  const std::uint32_t i = args->primID;
  RTCBounds* b = args->bounds_o;
  b->lower_x = u->boxes->min(0)[i];
  b->lower_y = u->boxes->min(1)[i];
  b->lower_z = u->boxes->min(2)[i];
  b->upper_x = u->boxes->max(0)[i];
  b->upper_y = u->boxes->max(1)[i];
  b->upper_z = u->boxes->max(2)[i];
}

Ray ray_of(const RTCRay& r) {
  Ray ray;
  ray.origin[0] = r.org_x, ray.origin[1] = r.org_y, ray.origin[2] = r.org_z;
  ray.dir[0] = r.dir_x, ray.dir[1] = r.dir_y, ray.dir[2] = r.dir_z;
  ray.tmin = r.tnear;
  ray.tmax = r.tfar;
  return ray;
}

void embree_intersect(const RTCIntersectFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto* u = static_cast<const EmbreeUser*>(args->geometryUserPtr);
  auto* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  const Ray ray = ray_of(rh->ray);
  double t;
  std::uint8_t part;
  if (!intersect_ray((*u->geometry)[args->primID], ray, ray.tmin, ray.tmax, t, part)) return;
  rh->ray.tfar = static_cast<float>(t);
  rh->hit.primID = args->primID;
  rh->hit.geomID = args->geomID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rh->hit.u = rh->hit.v = 0;
  rh->hit.Ng_x = rh->hit.Ng_y = 0;
  rh->hit.Ng_z = 1;
}

void embree_occluded(const RTCOccludedFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto* u = static_cast<const EmbreeUser*>(args->geometryUserPtr);
  auto* r = reinterpret_cast<RTCRay*>(args->ray);
  const Ray ray = ray_of(*r);
  double t;
  std::uint8_t part;
  if (intersect_ray((*u->geometry)[args->primID], ray, ray.tmin, ray.tmax, t, part))
    r->tfar = -std::numeric_limits<float>::infinity();
}

// An Embree scene of user geometry over `boxes` (one primitive per object).
class EmbreeScene {
 public:
  EmbreeScene(const BoxArray& boxes, const std::vector<ShapeGeometry>* geometry, RTCBuildQuality quality) {
    user_.boxes = &boxes;
    user_.geometry = geometry;
    device_ = rtcNewDevice(nullptr);
    scene_ = rtcNewScene(device_);
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_DYNAMIC);
    rtcSetSceneBuildQuality(scene_, quality == RTC_BUILD_QUALITY_REFIT ? RTC_BUILD_QUALITY_LOW : quality);
    geom_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom_, static_cast<unsigned>(boxes.size()));
    rtcSetGeometryUserData(geom_, &user_);
    rtcSetGeometryBoundsFunction(geom_, embree_bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom_, embree_intersect);
    rtcSetGeometryOccludedFunction(geom_, embree_occluded);
    rtcSetGeometryBuildQuality(geom_, quality);
    rtcCommitGeometry(geom_);
    rtcAttachGeometry(scene_, geom_);
    rtcCommitScene(scene_);
  }
  ~EmbreeScene() {
    rtcReleaseGeometry(geom_);
    rtcReleaseScene(scene_);
    rtcReleaseDevice(device_);
  }
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // The boxes changed (same array): rebuild or refit.
  void update() {
    rtcCommitGeometry(geom_);
    rtcCommitScene(scene_);
  }
  std::uint32_t closest(const Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    fill(ray, rh.ray);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx, &rh);
    return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? RayHit::kNone : rh.hit.primID;
  }
  bool occluded(const Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r{};
    fill(ray, r);
    rtcOccluded1(scene_, &ctx, &r);
    return r.tfar < 0;
  }

 private:
  static void fill(const Ray& ray, RTCRay& r) {
    r.org_x = static_cast<float>(ray.origin[0]);
    r.org_y = static_cast<float>(ray.origin[1]);
    r.org_z = static_cast<float>(ray.origin[2]);
    r.dir_x = static_cast<float>(ray.dir[0]);
    r.dir_y = static_cast<float>(ray.dir[1]);
    r.dir_z = static_cast<float>(ray.dir[2]);
    r.tnear = static_cast<float>(ray.tmin);
    r.tfar = ray.tmax > 3e38 ? std::numeric_limits<float>::infinity() : static_cast<float>(ray.tmax);
    r.mask = 0xFFFFFFFFu;
    r.time = 0;
    r.flags = 0;
  }

  EmbreeUser user_;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  RTCGeometry geom_ = nullptr;
};

// Partition + Embree's BVH over the scene: rebuilt per frame (quality LOW, the
// builder Embree uses for dynamic scenes) or refitted (quality REFIT).
void BM_Maintain_PartitionPlusEmbree(benchmark::State& state) {
  Frames frames(static_cast<std::uint32_t>(state.range(0)));
  KdPartition partition(kCellLimit, kXSplitWeight);
  const auto quality = static_cast<RTCBuildQuality>(state.range(1));
  std::unique_ptr<EmbreeScene> scene;
  run_frames(state, frames, [&](const BoxArray& boxes, bool) {
    partition.update(boxes);
    if (!scene) {
      scene = std::make_unique<EmbreeScene>(boxes, nullptr, quality);
    } else {
      scene->update();
    }
  });
  state.SetLabel(quality == RTC_BUILD_QUALITY_REFIT ? "embree refit" : "embree rebuild (low)");
}

#endif  // HBP_HAVE_EMBREE

// ---- ray throughput ------------------------------------------------------------

// One scene per n for every ray benchmark of the run: the hierarchy, our
// full-scene BVH, Embree's BVH, the primary rays of a kImage^2 view framing
// the cube and one shadow ray per primary hit (towards the renderer's light).
struct RayScene {
  explicit RayScene(std::uint32_t n) : frames(n) {
    for (std::uint32_t i = 0; i < kWarmFrames; ++i) hierarchy.update(i == 0 ? frames.boxes : frames.next());
    prepare_shapes(frames.scenario.shapes(), geometry);
    bvh::Scratch scratch;
    bvh::build(frames.boxes, full_bvh, scratch);
    const Aabb cube = frames.scenario.world_bounds();
    const Camera camera = frame_cube(cube, 1.0);
    const PointLight light = light_for_cube(cube);
    for (std::uint32_t y = 0; y < kImage; ++y)
      for (std::uint32_t x = 0; x < kImage; ++x) primary.push_back(camera.primary(x, y, kImage, kImage));
    hits.resize(primary.size());
    tbb::parallel_for(std::size_t{0}, primary.size(), [&](std::size_t i) {
      hits[i] = closest_hit(hierarchy, geometry, primary[i]);
    });
    double scale = cube.max[0] - cube.min[0];
    for (std::size_t i = 0; i < primary.size(); ++i) {
      if (!hits[i].hit()) continue;
      const Ray& r = primary[i];
      double p[3], nrm[3];
      for (int k = 0; k < 3; ++k) p[k] = r.origin[k] + hits[i].t * r.dir[k];
      surface_normal(geometry[hits[i].object], p, hits[i].part, nrm);
      if (nrm[0] * r.dir[0] + nrm[1] * r.dir[1] + nrm[2] * r.dir[2] > 0)
        for (double& v : nrm) v = -v;
      Ray s;
      for (int k = 0; k < 3; ++k) {
        s.origin[k] = p[k] + (1e-6 * scale + 1e-4) * nrm[k];
        s.dir[k] = light.position[k] - s.origin[k];
      }
      s.tmin = 0;
      s.tmax = 1;
      shadow.push_back(s);
    }
#ifdef HBP_HAVE_EMBREE
    embree = std::make_unique<EmbreeScene>(frames.boxes, &geometry, RTC_BUILD_QUALITY_MEDIUM);
    std::atomic<std::uint64_t> same{0};
    tbb::parallel_for(std::size_t{0}, primary.size(), [&](std::size_t i) {
      if (embree->closest(primary[i]) == hits[i].object) ++same;
    });
    embree_agreement = static_cast<double>(same.load()) / static_cast<double>(primary.size());
#endif
  }

  Frames frames;
  TwoLevelHierarchy hierarchy{{.cell_limit = kCellLimit, .x_split_weight = kXSplitWeight}};
  std::vector<ShapeGeometry> geometry;
  std::vector<BvhNode> full_bvh;
  std::vector<Ray> primary, shadow;
  std::vector<RayHit> hits;
#ifdef HBP_HAVE_EMBREE
  std::unique_ptr<EmbreeScene> embree;
  double embree_agreement = 0;
#endif
};

RayScene& ray_scene(std::uint32_t n) {
  static std::map<std::uint32_t, std::unique_ptr<RayScene>> scenes;
  auto& s = scenes[n];
  if (!s) s = std::make_unique<RayScene>(n);
  return *s;
}

template <class Trace>
void trace_rays(benchmark::State& state, const std::vector<Ray>& rays, Trace&& trace) {
  std::atomic<std::uint64_t> hits{0};
  const std::clock_t cpu_start = std::clock();  // process CPU time, all threads
  for (auto _ : state) {
    hits = 0;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 1024), [&](const auto& r) {
      std::uint64_t local = 0;
      for (std::size_t i = r.begin(); i != r.end(); ++i) local += trace(rays[i]) ? 1 : 0;
      hits += local;
    });
  }
  const double cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  const double traced = static_cast<double>(rays.size()) * static_cast<double>(state.iterations());
  // Throughput per CPU-second: what the machine's other load cannot inflate.
  state.counters["Mrays_per_cpu_s"] = cpu_s > 0 ? traced / 1e6 / cpu_s : 0;
  state.counters["rays"] = static_cast<double>(rays.size());
  state.counters["hit_fraction"] = static_cast<double>(hits.load()) / static_cast<double>(rays.size());
  state.counters["Mrays/s"] =
      benchmark::Counter(static_cast<double>(rays.size()) * static_cast<double>(state.iterations()) / 1e6,
                         benchmark::Counter::kIsRate);
}

void BM_Rays_Primary_SharedTwoLevel(benchmark::State& state) {
  RayScene& s = ray_scene(static_cast<std::uint32_t>(state.range(0)));
  trace_rays(state, s.primary, [&](const Ray& r) { return closest_hit(s.hierarchy, s.geometry, r).hit(); });
  state.counters["cells"] = s.hierarchy.cell_count();
}
void BM_Rays_Shadow_SharedTwoLevel(benchmark::State& state) {
  RayScene& s = ray_scene(static_cast<std::uint32_t>(state.range(0)));
  trace_rays(state, s.shadow, [&](const Ray& r) { return any_hit(s.hierarchy, s.geometry, r); });
}
void BM_Rays_Primary_OurFullSceneBvh(benchmark::State& state) {
  RayScene& s = ray_scene(static_cast<std::uint32_t>(state.range(0)));
  trace_rays(state, s.primary, [&](const Ray& r) { return closest_hit(s.full_bvh, s.geometry, r).hit(); });
}
void BM_Rays_Shadow_OurFullSceneBvh(benchmark::State& state) {
  RayScene& s = ray_scene(static_cast<std::uint32_t>(state.range(0)));
  trace_rays(state, s.shadow, [&](const Ray& r) { return any_hit(s.full_bvh, s.geometry, r); });
}
#ifdef HBP_HAVE_EMBREE
void BM_Rays_Primary_Embree(benchmark::State& state) {
  RayScene& s = ray_scene(static_cast<std::uint32_t>(state.range(0)));
  trace_rays(state, s.primary, [&](const Ray& r) { return s.embree->closest(r) != RayHit::kNone; });
  state.counters["same_object_as_ours"] = s.embree_agreement;
}
void BM_Rays_Shadow_Embree(benchmark::State& state) {
  RayScene& s = ray_scene(static_cast<std::uint32_t>(state.range(0)));
  trace_rays(state, s.shadow, [&](const Ray& r) { return s.embree->occluded(r); });
}
#endif

void sizes(benchmark::internal::Benchmark* b) {
  // Wall time, and CPU time of the whole process (all threads) for a machine
  // shared with other work.
  b->Arg(100000)->Arg(1024000)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
}
void maintenance(benchmark::internal::Benchmark* b) { sizes(b); b->Iterations(8); }
void rays(benchmark::internal::Benchmark* b) { sizes(b); b->Iterations(3); }

BENCHMARK(BM_Maintain_SharedTwoLevel)->Apply(maintenance);
BENCHMARK(BM_Maintain_PartitionOnly)->Apply(maintenance);
BENCHMARK(BM_Maintain_PartitionPlusOurBvhRefit)->Apply(maintenance);
BENCHMARK(BM_Maintain_PartitionPlusOurBvhRebuild)->Apply(maintenance);
#ifdef HBP_HAVE_EMBREE
BENCHMARK(BM_Maintain_PartitionPlusEmbree)
    ->ArgsProduct({{100000, 1024000}, {RTC_BUILD_QUALITY_LOW, RTC_BUILD_QUALITY_REFIT}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime()
    ->Iterations(8);
#endif
// Ray benchmarks of one n run together (the scene is built once per n).
BENCHMARK(BM_Rays_Primary_SharedTwoLevel)->Apply(rays);
BENCHMARK(BM_Rays_Shadow_SharedTwoLevel)->Apply(rays);
BENCHMARK(BM_Rays_Primary_OurFullSceneBvh)->Apply(rays);
BENCHMARK(BM_Rays_Shadow_OurFullSceneBvh)->Apply(rays);
#ifdef HBP_HAVE_EMBREE
BENCHMARK(BM_Rays_Primary_Embree)->Apply(rays);
BENCHMARK(BM_Rays_Shadow_Embree)->Apply(rays);
#endif

}  // namespace
