// SPDX-License-Identifier: MIT
#include "hbp/raytrace/renderer.hpp"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>

#include "hbp/error.hpp"
#include "hbp/raytrace/traversal.hpp"
#include "support/clock.hpp"

namespace hbp {

namespace {

constexpr float kAmbient = 0.22f;
constexpr float kEdge[3] = {0.85f, 0.85f, 0.8f};

std::uint8_t to_srgb8(float linear) {
  const float c = std::clamp(linear, 0.0f, 1.0f);
  const float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1 / 2.4f) - 0.055f;
  return static_cast<std::uint8_t>(std::lround(s * 255));
}

void background(double y, std::uint32_t height, float rgb[3]) {
  const float f = static_cast<float>(y / height);
  rgb[0] = 0.012f + 0.02f * f;
  rgb[1] = 0.014f + 0.025f * f;
  rgb[2] = 0.03f + 0.04f * f;
}

}  // namespace

void kind_colour(ShapeKind kind, float rgb[3]) {
  static constexpr float colours[kShapeKindCount][3] = {
      {0.70f, 0.10f, 0.06f},  // sphere: red
      {0.08f, 0.25f, 0.75f},  // cuboid: blue
      {0.10f, 0.50f, 0.12f},  // cylinder: green
      {0.85f, 0.55f, 0.05f},  // cone: amber
  };
  for (int k = 0; k < 3; ++k) rgb[k] = colours[static_cast<int>(kind)][k];
}

void collision_colour(float rgb[3]) {
  rgb[0] = 1.0f;
  rgb[1] = 0.05f;
  rgb[2] = 0.85f;
}

Image render(const TwoLevelHierarchy& h, std::span<const ShapeGeometry> geometry, const Aabb& cube,
             const RenderOptions& o, RenderStats* stats) {
  if (o.width == 0 || o.height == 0 || o.samples == 0 || o.tile == 0)
    throw InvalidInput("render: width, height, samples and tile must be positive");
  if (!o.highlight.empty() && o.highlight.size() != geometry.size())
    throw InvalidInput("render: highlight must have one flag per object");
  const auto start = SteadyClock::now();
  const Camera camera = frame_cube(cube, static_cast<double>(o.width) / o.height);
  const PointLight light = light_for_cube(cube);
  double scale = 0;
  for (int k = 0; k < 3; ++k) scale = std::max(scale, double(cube.max[k]) - cube.min[k]);
  const double offset = 1e-6 * scale + 1e-4;  // shadow rays leave the surface by this much

  Image img;
  img.width = o.width;
  img.height = o.height;
  std::vector<float> colour(3ull * o.width * o.height);
  std::vector<double> depth(static_cast<std::size_t>(o.width) * o.height, std::numeric_limits<double>::infinity());
  std::atomic<std::uint64_t> primary{0}, shadow{0}, hits{0};
  const std::uint32_t n = o.samples;

  tbb::parallel_for(
      tbb::blocked_range2d<std::uint32_t>(0, o.height, o.tile, 0, o.width, o.tile),
      [&](const tbb::blocked_range2d<std::uint32_t>& tile) {
        std::uint64_t tile_primary = 0, tile_shadow = 0, tile_hits = 0;
        for (std::uint32_t y = tile.rows().begin(); y != tile.rows().end(); ++y) {
          for (std::uint32_t x = tile.cols().begin(); x != tile.cols().end(); ++x) {
            float sum[3] = {0, 0, 0};
            double nearest = std::numeric_limits<double>::infinity();
            for (std::uint32_t sy = 0; sy < n; ++sy) {
              for (std::uint32_t sx = 0; sx < n; ++sx) {
                const double px = x + (sx + 0.5) / n - 0.5, py = y + (sy + 0.5) / n - 0.5;
                const Ray ray = camera.primary(px, py, o.width, o.height);
                ++tile_primary;
                const RayHit hit = closest_hit(h, geometry, ray);
                float c[3];
                if (!hit.hit()) {
                  background(py, o.height, c);
                } else {
                  ++tile_hits;
                  nearest = std::min(nearest, hit.t);
                  const ShapeGeometry& g = geometry[hit.object];
                  double p[3], normal[3];
                  for (int k = 0; k < 3; ++k) p[k] = ray.origin[k] + hit.t * ray.dir[k];
                  surface_normal(g, p, hit.part, normal);
                  if (normal[0] * ray.dir[0] + normal[1] * ray.dir[1] + normal[2] * ray.dir[2] > 0)
                    for (double& v : normal) v = -v;
                  double l[3], len = 0;
                  for (int k = 0; k < 3; ++k) {
                    l[k] = light.position[k] - p[k];
                    len += l[k] * l[k];
                  }
                  len = std::sqrt(len);
                  const double ndl = (normal[0] * l[0] + normal[1] * l[1] + normal[2] * l[2]) / len;
                  double lit = ndl > 0 ? ndl : 0;
                  if (lit > 0 && o.shadows) {
                    Ray s;
                    for (int k = 0; k < 3; ++k) {
                      s.origin[k] = p[k] + offset * normal[k];
                      s.dir[k] = light.position[k] - s.origin[k];
                    }
                    s.tmin = 0;
                    s.tmax = 1;  // the light is at t = 1
                    ++tile_shadow;
                    if (any_hit(h, geometry, s)) lit = 0;
                  }
                  float albedo[3];
                  if (!o.highlight.empty() && o.highlight[hit.object]) {
                    collision_colour(albedo);
                  } else {
                    kind_colour(g.kind, albedo);
                  }
                  const float shade = kAmbient + (1 - kAmbient) * static_cast<float>(lit);
                  for (int k = 0; k < 3; ++k) c[k] = albedo[k] * shade;
                }
                for (int k = 0; k < 3; ++k) sum[k] += c[k];
              }
            }
            const std::size_t i = static_cast<std::size_t>(y) * o.width + x;
            for (int k = 0; k < 3; ++k) colour[3 * i + k] = sum[k] / static_cast<float>(n * n);
            depth[i] = nearest;
          }
        }
        primary += tile_primary;
        shadow += tile_shadow;
        hits += tile_hits;
      });

  if (o.draw_cube) {
    // The cube's twelve edges, hidden where an object is in front.
    const double lo[3] = {cube.min[0], cube.min[1], cube.min[2]}, hi[3] = {cube.max[0], cube.max[1], cube.max[2]};
    const std::uint32_t steps = 4 * std::max(o.width, o.height);
    for (int axis = 0; axis < 3; ++axis) {
      for (int corner = 0; corner < 4; ++corner) {
        double a[3], b[3];
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        a[axis] = lo[axis];
        b[axis] = hi[axis];
        a[u] = b[u] = (corner & 1) ? hi[u] : lo[u];
        a[v] = b[v] = (corner & 2) ? hi[v] : lo[v];
        for (std::uint32_t s = 0; s <= steps; ++s) {
          const double f = static_cast<double>(s) / steps;
          const double p[3] = {a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])};
          double px, py, d;
          if (!camera.project(p, o.width, o.height, px, py, d)) continue;
          const long ix = std::lround(px), iy = std::lround(py);
          if (ix < 0 || iy < 0 || ix >= static_cast<long>(o.width) || iy >= static_cast<long>(o.height)) continue;
          const std::size_t i = static_cast<std::size_t>(iy) * o.width + static_cast<std::size_t>(ix);
          if (d > depth[i]) continue;
          for (int k = 0; k < 3; ++k) colour[3 * i + k] = kEdge[k];
        }
      }
    }
  }

  img.rgb.resize(colour.size());
  for (std::size_t i = 0; i < colour.size(); ++i) img.rgb[i] = to_srgb8(colour[i]);
  if (stats) {
    stats->primary_rays = primary.load();
    stats->shadow_rays = shadow.load();
    stats->hits = hits.load();
    stats->ms = ms_since(start);
  }
  return img;
}

}  // namespace hbp
