// SPDX-License-Identifier: MIT
// Exact ray-shape intersection (closed cases and a cross-check against the
// shapes' support functions), the PNG writer (round trip through libpng's
// reader) and the renderer (determinism, highlighting).
#include <gtest/gtest.h>
#include <png.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "hbp/error.hpp"
#include "hbp/raytrace/png_writer.hpp"
#include "hbp/raytrace/renderer.hpp"
#include "hbp/raytrace/traversal.hpp"
#include "hbp/scenario.hpp"

namespace hbp {
namespace {

Shape make(ShapeKind kind, Quat q = {}) { return Shape{kind, {20, 40, 60}, {0, 0, 0}, q}; }

Ray ray(double ox, double oy, double oz, double dx, double dy, double dz) {
  Ray r;
  r.origin[0] = ox, r.origin[1] = oy, r.origin[2] = oz;
  r.dir[0] = dx, r.dir[1] = dy, r.dir[2] = dz;
  return r;
}

struct Result {
  bool hit;
  double t;
  int part;
};
Result cast(const Shape& s, const Ray& r) {
  const ShapeGeometry g = prepare_shape(s);
  double t = 0;
  std::uint8_t part = 0;
  const bool hit = intersect_ray(g, r, r.tmin, r.tmax, t, part);
  return {hit, t, part};
}

TEST(RayShape, EllipsoidClosedCases) {
  const Shape s = make(ShapeKind::Sphere);  // semi-axes 10, 20, 30
  EXPECT_NEAR(cast(s, ray(-100, 0, 0, 1, 0, 0)).t, 90, 1e-9);
  EXPECT_NEAR(cast(s, ray(0, -100, 0, 0, 1, 0)).t, 80, 1e-9);
  EXPECT_NEAR(cast(s, ray(0, 0, 0, 0, 0, 1)).t, 30, 1e-9);   // from inside: on the way out
  EXPECT_NEAR(cast(s, ray(0, 0, 100, 0, 0, -2)).t, 35, 1e-9);  // t in units of |dir|
  EXPECT_FALSE(cast(s, ray(-100, 21, 0, 1, 0, 0)).hit);
  EXPECT_FALSE(cast(s, ray(100, 0, 0, 1, 0, 0)).hit);  // pointing away
  Ray r = ray(-100, 0, 0, 1, 0, 0);
  r.tmax = 89.9;
  EXPECT_FALSE(cast(s, r).hit);
}

TEST(RayShape, CuboidFacesAndRotation) {
  const Shape s = make(ShapeKind::Cuboid);  // half extents 10, 20, 30
  Result h = cast(s, ray(-100, 5, 5, 1, 0, 0));
  EXPECT_NEAR(h.t, 90, 1e-9);
  EXPECT_EQ(h.part, 0);  // -x face
  h = cast(s, ray(0, 0, 0, 0, 0, 1));
  EXPECT_NEAR(h.t, 30, 1e-9);
  EXPECT_EQ(h.part, 5);  // +z face, from inside
  EXPECT_FALSE(cast(s, ray(-100, 20.5, 0, 1, 0, 0)).hit);
  EXPECT_TRUE(cast(s, ray(-100, 20, 0, 1, 0, 0)).hit);  // grazing a face counts (closed)
  // 90 degrees about z: local x becomes world y.
  const double c = std::sqrt(0.5);
  const Shape r = make(ShapeKind::Cuboid, {c, 0, 0, c});
  EXPECT_NEAR(cast(r, ray(-100, 0, 0, 1, 0, 0)).t, 80, 1e-12);
  EXPECT_NEAR(cast(r, ray(0, -100, 0, 0, 1, 0)).t, 90, 1e-12);
}

TEST(RayShape, CylinderSideAndCaps) {
  const Shape s = make(ShapeKind::Cylinder);  // radii 10, 20; half height 30
  Result h = cast(s, ray(-100, 0, 0, 1, 0, 0));
  EXPECT_NEAR(h.t, 90, 1e-9);
  EXPECT_EQ(h.part, 0);
  h = cast(s, ray(0, 0, 100, 0, 0, -1));
  EXPECT_NEAR(h.t, 70, 1e-9);
  EXPECT_EQ(h.part, 1);
  h = cast(s, ray(3, 4, -100, 0, 0, 1));
  EXPECT_NEAR(h.t, 70, 1e-9);
  EXPECT_EQ(h.part, 2);
  EXPECT_FALSE(cast(s, ray(-100, 0, 30.5, 1, 0, 0)).hit);
  EXPECT_FALSE(cast(s, ray(9, 19, -100, 0, 0, 1)).hit);  // outside the ellipse (0.81 + 0.9025 > 1)
}

TEST(RayShape, ConeApexBaseAndSide) {
  const Shape s = make(ShapeKind::Cone);  // base radii 10, 20 at z = -30, apex at z = +30
  Result h = cast(s, ray(0, 0, 100, 0, 0, -1));
  EXPECT_NEAR(h.t, 70, 1e-9);  // the apex (a tangent double root)
  h = cast(s, ray(0, 0, -100, 0, 0, 1));
  EXPECT_NEAR(h.t, 70, 1e-9);
  EXPECT_EQ(h.part, 2);
  h = cast(s, ray(-100, 0, 0, 1, 0, 0));  // radius 5 at mid-height
  EXPECT_NEAR(h.t, 95, 1e-9);
  EXPECT_EQ(h.part, 0);
  EXPECT_FALSE(cast(s, ray(-100, 0, 31, 1, 0, 0)).hit);   // above the apex: no upper nappe
  EXPECT_FALSE(cast(s, ray(-100, 0, -31, 1, 0, 0)).hit);  // below the base
  EXPECT_FALSE(cast(s, ray(-100, 11, 0, 1, 0, 0)).hit);   // y radius 10 at mid-height
}

// A ray coming from far along d towards the shape's support point in d meets
// the shape exactly there: t = distance travelled (the support point is the
// shape's extreme in d). Checks the ray tests against shape.cpp's support
// functions, for random sizes and orientations.
TEST(RayShape, SupportPointIsWhereARayFromThatSideHits) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> size(25, 75), g(-1, 1), pos(-500, 500);
  int checked = 0;
  for (int i = 0; i < 4000; ++i) {
    Shape s;
    s.kind = static_cast<ShapeKind>(i % 4);
    s.size = {size(rng), size(rng), size(rng)};
    s.position = {pos(rng), pos(rng), pos(rng)};
    s.orientation = normalized({g(rng), g(rng), g(rng), g(rng)});
    Vec3 d{g(rng), g(rng), g(rng)};
    const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    if (len < 0.1) continue;
    d = {d.x / len, d.y / len, d.z / len};
    const Vec3 p = support_point(s, d);
    const double far = 1000;
    const Result h = cast(s, ray(p.x + far * d.x, p.y + far * d.y, p.z + far * d.z, -d.x, -d.y, -d.z));
    ASSERT_TRUE(h.hit) << i;
    EXPECT_NEAR(h.t, far, 1e-7 * far) << "kind " << i % 4 << " shape " << i;
    // The hit point lies in the shape's tight AABB, and the normal faces d.
    const ShapeGeometry geo = prepare_shape(s);
    const double q[3] = {p.x + (far - h.t) * d.x, p.y + (far - h.t) * d.y, p.z + (far - h.t) * d.z};
    // (Support points lie on edges and rims, where a ray meets two surfaces
    // at a near-double root: t is accurate to about sqrt(double eps) there.)
    const Aabb box = tight_aabb(s);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(q[k], box.min[k] - 1e-4);
      EXPECT_LE(q[k], box.max[k] + 1e-4);
    }
    double n[3];
    surface_normal(geo, q, static_cast<std::uint8_t>(h.part), n);
    EXPECT_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1, 1e-12);
    // The surface hit faces the incoming ray (-d). Support points of the
    // other shapes lie on edges, rims or the apex, where the normal is not
    // defined.
    if (s.kind == ShapeKind::Sphere) {
      EXPECT_GT(n[0] * d.x + n[1] * d.y + n[2] * d.z, 1 - 1e-6);
    }
    ++checked;
  }
  EXPECT_GT(checked, 3500);
}

// Rays towards the centre always hit (the centre is inside every shape), at a
// point where the shape's implicit surface equation holds.
TEST(RayShape, HitsLieOnTheSurface) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> size(25, 75), g(-1, 1);
  for (int i = 0; i < 4000; ++i) {
    Shape s;
    s.kind = static_cast<ShapeKind>(i % 4);
    s.size = {size(rng), size(rng), size(rng)};
    s.orientation = normalized({g(rng), g(rng), g(rng), g(rng)});
    const double o[3] = {300 * g(rng), 300 * g(rng), 300 * g(rng)};
    const Result h = cast(s, ray(o[0], o[1], o[2], -o[0], -o[1], -o[2]));
    ASSERT_TRUE(h.hit);
    const ShapeGeometry geo = prepare_shape(s);
    double w[3], l[3];
    for (int k = 0; k < 3; ++k) w[k] = o[k] - h.t * o[k];
    for (int j = 0; j < 3; ++j) l[j] = geo.rot[0][j] * w[0] + geo.rot[1][j] * w[1] + geo.rot[2][j] * w[2];
    const double* hh = geo.half;
    const double x = l[0] / hh[0], y = l[1] / hh[1], z = l[2] / hh[2];
    double f = 0;  // 1 on the surface
    switch (s.kind) {
      case ShapeKind::Sphere: f = std::sqrt(x * x + y * y + z * z); break;
      case ShapeKind::Cuboid: f = std::max({std::fabs(x), std::fabs(y), std::fabs(z)}); break;
      case ShapeKind::Cylinder: f = std::max(std::sqrt(x * x + y * y), std::fabs(z)); break;
      case ShapeKind::Cone: f = std::max(std::sqrt(x * x + y * y) / (0.5 * (1 - z)), -z); break;
    }
    EXPECT_NEAR(f, 1, 1e-9) << "kind " << i % 4;
  }
}

// ---- PNG ---------------------------------------------------------------------

// Decodes a PNG with libpng (independent of how it was written) into RGB.
std::vector<std::uint8_t> decode_png(const std::vector<std::uint8_t>& png, std::uint32_t& width,
                                     std::uint32_t& height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, png.data(), png.size())) {
    ADD_FAILURE() << "libpng cannot read the header: " << image.message;
    return {};
  }
  image.format = PNG_FORMAT_RGB;
  width = image.width;
  height = image.height;
  std::vector<std::uint8_t> rgb(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) {
    ADD_FAILURE() << "libpng cannot read the pixels: " << image.message;
    return {};
  }
  return rgb;
}

TEST(PngWriter, ImageRoundTrip) {
  const std::uint32_t w = 37, h = 23;
  std::vector<std::uint8_t> rgb(3 * w * h);
  std::mt19937 rng(4);
  for (std::uint32_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>((i / 3) % w * 5 + (rng() % 3));
  const auto png = encode_png(w, h, rgb);
  ASSERT_EQ(std::memcmp(png.data(), "\x89PNG\r\n\x1a\n", 8), 0);
  std::uint32_t dw = 0, dh = 0;
  const auto out = decode_png(png, dw, dh);
  EXPECT_EQ(dw, w);
  EXPECT_EQ(dh, h);
  EXPECT_EQ(out, rgb);
}

TEST(PngWriter, CompressesFlatImagesAndRefusesBadSizes) {
  const std::uint32_t w = 200, h = 100;
  std::vector<std::uint8_t> rgb(3 * w * h, 7);
  for (std::uint32_t i = 0; i < rgb.size(); i += 301) rgb[i] = static_cast<std::uint8_t>(i % 251);
  const auto png = encode_png(w, h, rgb);
  EXPECT_LT(png.size(), rgb.size() / 3);
  std::uint32_t dw = 0, dh = 0;
  EXPECT_EQ(decode_png(png, dw, dh), rgb);
  EXPECT_THROW(encode_png(w, h + 1, rgb), InvalidInput);
  EXPECT_THROW(encode_png(0, h, {}), InvalidInput);
}

TEST(PngWriter, WritesTheFileAndNamesAnUnwritablePath) {
  const std::uint32_t w = 5, h = 3;
  std::vector<std::uint8_t> rgb(3 * w * h);
  for (std::uint32_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>(i * 17);
  const std::string path = ::testing::TempDir() + "png writer test.png";
  write_png(path, w, h, rgb);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  ASSERT_NE(f, nullptr);
  std::vector<std::uint8_t> bytes;
  for (int c; (c = std::fgetc(f)) != EOF;) bytes.push_back(static_cast<std::uint8_t>(c));
  std::fclose(f);
  std::remove(path.c_str());
  EXPECT_EQ(bytes, encode_png(w, h, rgb));
  const std::string bad = ::testing::TempDir() + "no such dir/x.png";
  try {
    write_png(bad, w, h, rgb);
    ADD_FAILURE() << "no exception";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
}

// ---- renderer ---------------------------------------------------------------

TEST(Renderer, DeterministicAcrossThreadCountsAndHighlights) {
  ScenarioParams sp;
  sp.n = 100;
  Scenario scenario(sp);
  BoxArray boxes;
  scenario.compute_boxes(boxes);
  TwoLevelHierarchy h({.cell_limit = 16});
  h.update(boxes);
  std::vector<ShapeGeometry> geometry;
  prepare_shapes(scenario.shapes(), geometry);
  RenderOptions o;
  o.width = 96;
  o.height = 64;
  RenderStats one, two;
  Image a, b;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    a = render(h, geometry, scenario.world_bounds(), o, &one);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    b = render(h, geometry, scenario.world_bounds(), o, &two);
  }
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(one.primary_rays, 96u * 64u);
  EXPECT_GT(one.hits, 96u * 64u / 10);
  EXPECT_LE(one.shadow_rays, one.hits);
  EXPECT_GT(one.shadow_rays, 0u);

  auto magenta = [](const Image& img) {
    int count = 0;
    for (std::size_t i = 0; i < img.rgb.size(); i += 3)
      count += img.rgb[i] > 150 && img.rgb[i + 1] < 90 && img.rgb[i + 2] > 120;
    return count;
  };
  EXPECT_EQ(magenta(a), 0);
  const std::vector<std::uint8_t> all(scenario.size(), 1);
  o.highlight = all;
  const Image c = render(h, geometry, scenario.world_bounds(), o);
  EXPECT_GT(magenta(c), static_cast<int>(one.hits / 4));
}

}  // namespace
}  // namespace hbp
