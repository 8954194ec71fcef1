// Exact ray-shape intersection (closed cases and a cross-check against the
// shapes' support functions), the PNG writer (round trip through an
// independent inflater) and the renderer (determinism, highlighting).
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

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

// An independent inflater for what the writer emits (fixed-Huffman blocks).
std::vector<std::uint8_t> inflate_fixed(const std::vector<std::uint8_t>& z) {
  std::size_t bitpos = 16;  // after the zlib header
  auto bit = [&]() -> std::uint32_t {
    const std::uint32_t b = (z.at(bitpos / 8) >> (bitpos % 8)) & 1u;
    ++bitpos;
    return b;
  };
  auto bits = [&](int n) {
    std::uint32_t v = 0;
    for (int i = 0; i < n; ++i) v |= bit() << i;
    return v;
  };
  static const int len_base[] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
  static const int len_extra[] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
  std::vector<std::uint8_t> out;
  bool final_block = false;
  while (!final_block) {
    final_block = bit();
    EXPECT_EQ(bits(2), 1u);  // fixed Huffman
    for (;;) {
      std::uint32_t code = 0;
      int sym = -1;
      for (int len = 1; len <= 9 && sym < 0; ++len) {
        code = code << 1 | bit();
        if (len == 7 && code <= 23) sym = 256 + static_cast<int>(code);
        if (len == 8 && code >= 48 && code <= 191) sym = static_cast<int>(code) - 48;
        if (len == 8 && code >= 192 && code <= 199) sym = 280 + static_cast<int>(code) - 192;
        if (len == 9 && code >= 400) sym = 144 + static_cast<int>(code) - 400;
      }
      if (sym < 256) {
        out.push_back(static_cast<std::uint8_t>(sym));
        continue;
      }
      if (sym == 256) break;
      const int length = len_base[sym - 257] + static_cast<int>(bits(len_extra[sym - 257]));
      std::uint32_t dcode = 0;
      for (int i = 0; i < 5; ++i) dcode = dcode << 1 | bit();
      int dist = 1, extra = 0;
      for (std::uint32_t c = 0; c < dcode; ++c) {  // distance bases by recurrence
        dist += 1 << extra;
        if (c >= 2 && c % 2 == 1) ++extra;
      }
      dist += static_cast<int>(bits(extra));
      for (int i = 0; i < length; ++i) out.push_back(out[out.size() - dist]);
    }
  }
  return out;
}

std::uint32_t be32(const std::uint8_t* p) { return std::uint32_t(p[0]) << 24 | p[1] << 16 | p[2] << 8 | p[3]; }

TEST(PngWriter, ChecksumsOfKnownStrings) {
  const std::string a = "123456789", b = "Wikipedia";
  EXPECT_EQ(crc32({reinterpret_cast<const std::uint8_t*>(a.data()), a.size()}), 0xCBF43926u);
  EXPECT_EQ(adler32({reinterpret_cast<const std::uint8_t*>(b.data()), b.size()}), 0x11E60398u);
}

TEST(PngWriter, DeflateRoundTripsAndCompressesFlatData) {
  std::mt19937 rng(3);
  std::vector<std::uint8_t> data;
  for (int i = 0; i < 70000; ++i) data.push_back(static_cast<std::uint8_t>(i % 300 < 200 ? 7 : rng() % 4));
  const auto z = zlib_compress(data);
  EXPECT_EQ(inflate_fixed(z), data);
  EXPECT_LT(z.size(), data.size() / 3);
  EXPECT_EQ(be32(&z[z.size() - 4]), adler32(data));
}

TEST(PngWriter, ImageRoundTrip) {
  const std::uint32_t w = 37, h = 23;
  std::vector<std::uint8_t> rgb(3 * w * h);
  std::mt19937 rng(4);
  for (std::uint32_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>((i / 3) % w * 5 + (rng() % 3));
  const auto png = encode_png(w, h, rgb);
  ASSERT_EQ(std::memcmp(png.data(), "\x89PNG\r\n\x1a\n", 8), 0);
  std::vector<std::uint8_t> idat;
  for (std::size_t at = 8; at < png.size();) {
    const std::uint32_t len = be32(&png[at]);
    const std::string type(reinterpret_cast<const char*>(&png[at + 4]), 4);
    EXPECT_EQ(crc32({&png[at + 4], len + 4}), be32(&png[at + 8 + len])) << type;
    if (type == "IHDR") {
      EXPECT_EQ(be32(&png[at + 8]), w);
      EXPECT_EQ(be32(&png[at + 12]), h);
    }
    if (type == "IDAT") idat.insert(idat.end(), &png[at + 8], &png[at + 8 + len]);
    at += 12 + len;
  }
  const auto raw = inflate_fixed(idat);
  ASSERT_EQ(raw.size(), (3 * w + 1) * h);
  // Undo the filters.
  std::vector<std::uint8_t> out(3 * w * h);
  for (std::uint32_t y = 0; y < h; ++y) {
    const std::uint8_t f = raw[y * (3 * w + 1)];
    ASSERT_LE(f, 4);
    for (std::uint32_t x = 0; x < 3 * w; ++x) {
      const int a = x >= 3 ? out[y * 3 * w + x - 3] : 0, b = y > 0 ? out[(y - 1) * 3 * w + x] : 0,
                c = (x >= 3 && y > 0) ? out[(y - 1) * 3 * w + x - 3] : 0;
      int pred = 0;
      if (f == 1) pred = a;
      if (f == 2) pred = b;
      if (f == 3) pred = (a + b) / 2;
      if (f == 4) {
        const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
        pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
      }
      out[y * 3 * w + x] = static_cast<std::uint8_t>(raw[y * (3 * w + 1) + 1 + x] + pred);
    }
  }
  EXPECT_EQ(out, rgb);
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
