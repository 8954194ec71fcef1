// SPDX-License-Identifier: MIT
#pragma once
// The ray tracer over the shared two-level hierarchy: one primary ray per
// pixel (or n x n), one shadow ray to a point light per hit, Lambert shading,
// a colour per shape kind, the cube's edges, tiles rendered in parallel.
//
//   hbp::Image img = hbp::render(hierarchy, geometry, scenario.world_bounds(), {.width = 800, .height = 800});
//   hbp::write_png("fig.png", img.width, img.height, img.rgb);
#include <cstdint>
#include <span>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/raytrace/camera.hpp"
#include "hbp/raytrace/ray_shape.hpp"
#include "hbp/two_level_hierarchy.hpp"

namespace hbp {

struct RenderOptions {
  std::uint32_t width = 800, height = 800;
  std::uint32_t samples = 1;  // n x n primary rays per pixel
  bool shadows = true;
  bool draw_cube = true;
  // Per object, non-zero: drawn in the collision colour (empty: none).
  std::span<const std::uint8_t> highlight;
  std::uint32_t tile = 16;
};

struct RenderStats {
  std::uint64_t primary_rays = 0, shadow_rays = 0, hits = 0;
  double ms = 0;
};

struct Image {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // row-major, 3 bytes per pixel
};

// Linear RGB albedo of each shape kind, and of colliding objects.
void kind_colour(ShapeKind kind, float rgb[3]);
void collision_colour(float rgb[3]);

// Renders `geometry` (indexed by object id, as the hierarchy's leaves) with
// the camera and light framing `cube`.
Image render(const TwoLevelHierarchy& hierarchy, std::span<const ShapeGeometry> geometry, const Aabb& cube,
             const RenderOptions& options, RenderStats* stats = nullptr);

}  // namespace hbp
