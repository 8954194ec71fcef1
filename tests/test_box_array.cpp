// SPDX-License-Identifier: MIT
// BoxArray: the SoA container every engine reads. Alignment and padding are
// what lets SIMD kernels read whole vectors past size(); validate() is what
// turns a bad box into a message a user can act on.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/error.hpp"

namespace {

using hbp::Aabb;
using hbp::BoxArray;

constexpr float kInf = std::numeric_limits<float>::infinity();

Aabb box_for(std::size_t i) {
  const float f = static_cast<float>(i);
  return {{f, -f, 2 * f}, {f + 1, -f + 0.5f, 2 * f + 3}};
}

// Every lane is 64-byte aligned, capacity is a whole number of 16-float
// vectors, and every slot from size() to capacity() is the padding box
// (min = +inf, max = -inf), which overlaps nothing, not even itself.
void expect_invariants(const BoxArray& b, const std::string& what) {
  ASSERT_GT(b.capacity(), b.size()) << what;
  EXPECT_EQ(b.capacity() % BoxArray::kPadFloats, 0u) << what;
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(b.min(k)) % BoxArray::kAlignment, 0u) << what;
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(b.max(k)) % BoxArray::kAlignment, 0u) << what;
    for (std::size_t i = b.size(); i < b.capacity(); ++i) {
      ASSERT_EQ(b.min(k)[i], kInf) << what << " lane min " << k << " slot " << i;
      ASSERT_EQ(b.max(k)[i], -kInf) << what << " lane max " << k << " slot " << i;
    }
  }
}

void expect_boxes(const BoxArray& b, std::size_t n, const std::string& what) {
  ASSERT_EQ(b.size(), n) << what;
  for (std::size_t i = 0; i < n; ++i) {
    const Aabb e = box_for(i), g = b.get(i);
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(g.min[k], e.min[k]) << what << " box " << i;
      ASSERT_EQ(g.max[k], e.max[k]) << what << " box " << i;
    }
  }
}

TEST(BoxArray, PaddingAndAlignmentThroughGrowthAndShrinking) {
  BoxArray b;
  for (std::size_t i = 0; i < 100; ++i) {
    b.push_back(box_for(i));
    expect_invariants(b, "push_back " + std::to_string(i));
  }
  expect_boxes(b, 100, "after push_back");
  b.resize(37);  // the dropped boxes become padding again
  expect_invariants(b, "shrunk");
  expect_boxes(b, 37, "shrunk");
  const std::size_t cap = b.capacity();
  b.resize(90);  // regrowing within the capacity yields padding boxes, not stale ones
  EXPECT_EQ(b.capacity(), cap);
  for (std::size_t i = 37; i < 90; ++i) ASSERT_EQ(b.get(i).min[0], kInf) << i;
  b.clear();
  expect_invariants(b, "cleared");
  EXPECT_TRUE(b.empty());
}

TEST(BoxArray, SizesAroundVectorBoundaries) {
  for (std::size_t n : {0u, 1u, 15u, 16u, 17u, 31u, 32u, 33u, 1000u}) {
    BoxArray b(n);
    expect_invariants(b, "n = " + std::to_string(n));
    // New boxes are the padding box too, until set.
    if (n > 0) {
      EXPECT_EQ(b.get(n - 1).max[2], -kInf);
    }
  }
}

TEST(BoxArray, PaddingBoxOverlapsNothing) {
  const Aabb pad{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};
  const Aabb everything{{-std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                         -std::numeric_limits<float>::max()},
                        {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                         std::numeric_limits<float>::max()}};
  EXPECT_FALSE(hbp::overlaps(pad, everything));
  EXPECT_FALSE(hbp::overlaps(everything, pad));
  EXPECT_FALSE(hbp::overlaps(pad, pad));
}

TEST(BoxArray, CopiesAreDeepAndKeepInvariants) {
  BoxArray a;
  for (std::size_t i = 0; i < 50; ++i) a.push_back(box_for(i));
  BoxArray b(a);
  expect_boxes(b, 50, "copy");
  expect_invariants(b, "copy");
  b.set(0, box_for(7));
  EXPECT_EQ(a.get(0).min[0], 0.0f);  // the original is untouched
  BoxArray c(500);
  c = a;  // assigning a smaller array restores padding past its size
  expect_boxes(c, 50, "assigned");
  expect_invariants(c, "assigned");
  const BoxArray& alias = c;
  c = alias;  // self-assignment is harmless
  expect_boxes(c, 50, "self-assigned");
}

TEST(BoxArray, MovedFromArrayIsEmptyAndReusable) {
  BoxArray a;
  for (std::size_t i = 0; i < 40; ++i) a.push_back(box_for(i));
  BoxArray b(std::move(a));
  expect_boxes(b, 40, "moved-to");
  // A moved-from array must be valid: empty, and usable again.
  EXPECT_EQ(a.size(), 0u);  // NOLINT(bugprone-use-after-move): this is the point
  a.resize(20);
  for (std::size_t i = 0; i < 20; ++i) a.set(i, box_for(i));
  expect_boxes(a, 20, "reused");
  expect_invariants(a, "reused");
  BoxArray c;
  c = std::move(b);
  expect_boxes(c, 40, "move-assigned");
  EXPECT_EQ(b.size(), 0u);  // NOLINT(bugprone-use-after-move)
  b.push_back(box_for(0));
  expect_boxes(b, 1, "reused after move-assign");
}

std::string validate_message(const BoxArray& b, const char* what) {
  try {
    b.validate(what);
  } catch (const hbp::InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(BoxArray, ValidateNamesObjectAxisAndDefect) {
  BoxArray b;
  for (std::size_t i = 0; i < 10; ++i) b.push_back(box_for(i));
  EXPECT_EQ(validate_message(b, "boxes"), "");
  b.min(1)[3] = std::numeric_limits<float>::quiet_NaN();
  std::string m = validate_message(b, "scene.hbps frame 2");
  EXPECT_EQ(m.rfind("scene.hbps frame 2: object 3: NaN coordinate on axis y", 0), 0u) << m;
  b.set(3, box_for(3));
  b.max(2)[8] = kInf;
  m = validate_message(b, "boxes");
  EXPECT_EQ(m.rfind("boxes: object 8: infinite coordinate on axis z", 0), 0u) << m;
  b.set(8, box_for(8));
  b.min(0)[5] = 100.0f;
  m = validate_message(b, "boxes");
  EXPECT_EQ(m.rfind("boxes: object 5: min > max on axis x (min 100", 0), 0u) << m;
  // The first bad object is reported.
  b.min(0)[2] = 100.0f;
  EXPECT_NE(validate_message(b, "boxes").find("object 2"), std::string::npos);
}

TEST(BoxArray, ValidAndEmptyArraysPass) {
  BoxArray empty;
  EXPECT_NO_THROW(empty.validate());
  BoxArray b;
  b.push_back({{0, 0, 0}, {0, 0, 0}});  // a point is valid
  b.push_back({{-0.0f, 0, 0}, {0.0f, 0, 0}});
  EXPECT_NO_THROW(b.validate());
}

TEST(BoxDefect, EachDefect) {
  EXPECT_EQ(hbp::box_defect({{0, 0, 0}, {1, 1, 1}}), nullptr);
  EXPECT_STREQ(hbp::box_defect({{0, NAN, 0}, {1, 1, 1}}), "NaN coordinate");
  EXPECT_STREQ(hbp::box_defect({{0, 0, 0}, {1, 1, -kInf}}), "infinite coordinate");
  EXPECT_STREQ(hbp::box_defect({{0, 0, 2}, {1, 1, 1}}), "min > max");
}

TEST(Overlaps, ClosedIntervalsOnEveryAxis) {
  const Aabb a{{0, 0, 0}, {1, 1, 1}};
  for (int k = 0; k < 3; ++k) {
    Aabb touching = a, apart = a;
    touching.min[k] = 1;
    touching.max[k] = 2;
    apart.min[k] = std::nextafter(1.0f, 2.0f);
    apart.max[k] = 2;
    EXPECT_TRUE(hbp::overlaps(a, touching)) << k;
    EXPECT_TRUE(hbp::overlaps(touching, a)) << k;
    EXPECT_FALSE(hbp::overlaps(a, apart)) << k;
    EXPECT_FALSE(hbp::overlaps(apart, a)) << k;
  }
}

}  // namespace
