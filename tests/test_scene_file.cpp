// SPDX-License-Identifier: MIT
// Scene files: round trips of both formats, Broadmark's byte layout as its
// source defines it, every corruption giving the right error, streaming.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"

namespace {

namespace fs = std::filesystem;
using hbp::Aabb;
using hbp::BoxArray;
using hbp::SceneFormat;
using hbp::SceneReader;
using hbp::SceneWriter;

// A fresh path per test in the test temp directory, removed afterwards.
class SceneFileTest : public ::testing::Test {
 protected:
  std::string path(const std::string& name) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const fs::path p = fs::path(::testing::TempDir()) /
                       ("hbp_" + std::to_string(::getpid()) + "_" + info->name() + "_" + name);
    created_.push_back(p);
    return p.string();
  }
  void TearDown() override {
    for (const auto& p : created_) fs::remove(p);
  }

 private:
  std::vector<fs::path> created_;
};

// Box i of frame k encodes (k, i), so a misplaced read cannot go unnoticed.
Aabb encoded_box(std::uint32_t k, std::uint32_t i) {
  const float x = static_cast<float>(i) * 0.5f, y = static_cast<float>(k) * 3.0f - 7.25f, z = -static_cast<float>(i);
  return {{x, y, z}, {x + 1.5f + static_cast<float>(k), y + 0.25f, z + static_cast<float>(i % 3)}};
}

BoxArray encoded_frame(std::uint32_t k, std::uint32_t n) {
  BoxArray b(n);
  for (std::uint32_t i = 0; i < n; ++i) b.set(i, encoded_box(k, i));
  return b;
}

const Aabb kWorld{{-100, -50, -25}, {100, 50, 25}};

void expect_same_boxes(const BoxArray& expected, const BoxArray& actual, const std::string& what) {
  ASSERT_EQ(expected.size(), actual.size()) << what;
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_EQ(0, std::memcmp(expected.min(axis), actual.min(axis), expected.size() * sizeof(float))) << what;
    EXPECT_EQ(0, std::memcmp(expected.max(axis), actual.max(axis), expected.size() * sizeof(float))) << what;
  }
}

void write_scene(const std::string& file, SceneFormat format, std::uint32_t n, std::uint32_t frames,
                 const std::string& name = "hbp", const std::string& type = "paper") {
  SceneWriter w(file, format, n, kWorld, name, type);
  for (std::uint32_t k = 0; k < frames; ++k) w.write_frame(encoded_frame(k, n));
  w.close();
}

std::vector<unsigned char> read_bytes(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& file, const std::vector<unsigned char>& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

template <typename T>
void poke(std::vector<unsigned char>& bytes, std::size_t offset, T value) {
  ASSERT_LE(offset + sizeof(T), bytes.size());
  std::memcpy(bytes.data() + offset, &value, sizeof(T));
}

template <typename T>
T peek(const std::vector<unsigned char>& bytes, std::size_t offset) {
  T v;
  std::memcpy(&v, bytes.data() + offset, sizeof(T));
  return v;
}

// Runs f, expects exception E whose message contains every one of `parts`.
template <typename E, typename F>
void expect_error(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one mentioning '" << parts.front() << "'";
  } catch (const E& e) {
    const std::string msg = e.what();
    for (const auto& part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type: " << e.what();
  }
}

// ---- Round trips -------------------------------------------------------------

TEST_F(SceneFileTest, NativeRoundTripIsBitExactAndInAnyOrder) {
  const auto file = path("rt.hbps");
  write_scene(file, SceneFormat::Native, 1000, 5, "paper seed=3", "sphere/cuboid/cylinder/cone");
  EXPECT_EQ(hbp::detect_scene_format(file), SceneFormat::Native);
  SceneReader r(file);
  EXPECT_EQ(r.info().format, SceneFormat::Native);
  EXPECT_EQ(r.info().object_count, 1000u);
  EXPECT_EQ(r.info().frame_count, 5u);
  EXPECT_EQ(r.info().version, 1u);
  EXPECT_EQ(r.info().name, "paper seed=3");
  EXPECT_EQ(r.info().objects_type, "sphere/cuboid/cylinder/cone");
  EXPECT_EQ(0, std::memcmp(&r.info().world, &kWorld, sizeof(Aabb)));
  EXPECT_EQ(r.info().file_bytes, 320u + 5u * 1000u * 24u);
  EXPECT_EQ(fs::file_size(file), hbp::scene_file_bytes(SceneFormat::Native, 1000, 5));
  BoxArray b;
  for (std::uint32_t k : {3u, 0u, 4u, 1u, 2u, 3u}) {
    r.read_frame(k, b);
    expect_same_boxes(encoded_frame(k, 1000), b, "frame " + std::to_string(k));
  }
}

TEST_F(SceneFileTest, BroadmarkRoundTripCountsTheInitialStateAsAFrame) {
  const auto file = path("rt.aabbs");
  write_scene(file, SceneFormat::Broadmark, 20000, 4, "Brownian", "Cubes");  // > one 8192-object chunk
  EXPECT_EQ(hbp::detect_scene_format(file), SceneFormat::Broadmark);
  const auto bytes = read_bytes(file);
  EXPECT_EQ(peek<std::int32_t>(bytes, 260), 3);  // numberOfFrames excludes frame 0
  SceneReader r(file);
  EXPECT_EQ(r.info().format, SceneFormat::Broadmark);
  EXPECT_EQ(r.info().object_count, 20000u);
  EXPECT_EQ(r.info().frame_count, 4u);
  EXPECT_EQ(r.info().name, "Brownian");
  EXPECT_EQ(r.info().objects_type, "Cubes");
  EXPECT_EQ(0, std::memcmp(&r.info().world, &kWorld, sizeof(Aabb)));
  EXPECT_EQ(fs::file_size(file), 304u + 4u * 20000u * 32u);
  BoxArray b;
  for (std::uint32_t k : {2u, 0u, 3u, 1u}) {
    r.read_frame(k, b);
    expect_same_boxes(encoded_frame(k, 20000), b, "frame " + std::to_string(k));
  }
}

TEST_F(SceneFileTest, SpecialButValidValuesSurvive) {
  // Signed zero, denormals, point boxes and huge finite values are all valid.
  BoxArray b(4);
  const float big = std::numeric_limits<float>::max(), tiny = std::numeric_limits<float>::denorm_min();
  b.set(0, {{-0.0f, 0.0f, -0.0f}, {0.0f, 0.0f, 0.0f}});
  b.set(1, {{tiny, -tiny, 0}, {tiny, tiny, 0}});
  b.set(2, {{-big, -big, -big}, {big, big, big}});
  b.set(3, {{5, 5, 5}, {5, 5, 5}});
  for (auto format : {SceneFormat::Native, SceneFormat::Broadmark}) {
    const auto file = path(std::string("special.") + hbp::scene_format_name(format));
    {
      SceneWriter w(file, format, 4, kWorld);
      w.write_frame(b);
    }  // the destructor closes
    SceneReader r(file);
    BoxArray got;
    r.read_frame(0, got);
    expect_same_boxes(b, got, hbp::scene_format_name(format));
    EXPECT_TRUE(std::signbit(got.min(0)[0]));
  }
}

TEST_F(SceneFileTest, EmptyNativeScenesAreValid) {
  const auto no_frames = path("noframes.hbps"), no_objects = path("noobjects.hbps");
  write_scene(no_frames, SceneFormat::Native, 10, 0);
  write_scene(no_objects, SceneFormat::Native, 0, 3);
  SceneReader a(no_frames);
  EXPECT_EQ(a.info().frame_count, 0u);
  BoxArray b;
  expect_error<hbp::InvalidInput>([&] { a.read_frame(0, b); }, {"frame 0 does not exist"});
  SceneReader c(no_objects);
  EXPECT_EQ(c.info().frame_count, 3u);
  c.read_frame(2, b);
  EXPECT_EQ(b.size(), 0u);
}

// ---- Broadmark layout, byte by byte ------------------------------------------

// Builds a file the way Broadmark's generator (AABBsRecorder.cs) does, from
// the field list of Core/Scene.h, without our writer.
std::vector<unsigned char> broadmark_file(const std::vector<std::vector<Aabb>>& frames, const Aabb& world) {
  std::vector<unsigned char> out(304, 0);
  std::memcpy(out.data(), "Brownian Cubes", 14);
  std::memcpy(out.data() + 128, "Cubes", 5);
  std::int32_t n = static_cast<std::int32_t>(frames.front().size());
  std::int32_t timed = static_cast<std::int32_t>(frames.size()) - 1;
  std::memcpy(out.data() + 256, &n, 4);
  std::memcpy(out.data() + 260, &timed, 4);
  auto put_box = [&](std::size_t at, const Aabb& b) {
    const float rec[8] = {b.min[0], b.min[1], b.min[2], 0.0f, b.max[0], b.max[1], b.max[2], 0.0f};
    if (out.size() < at + 32) out.resize(at + 32);
    std::memcpy(out.data() + at, rec, 32);
  };
  put_box(272, world);
  std::size_t at = 304;
  for (const auto& frame : frames)
    for (const auto& b : frame) {
      put_box(at, b);
      at += 32;
    }
  return out;
}

TEST_F(SceneFileTest, ReadsAFileLaidOutAsBroadmarksGeneratorWritesIt) {
  const Aabb world{{-500, -500, -500}, {500, 500, 500}};
  const std::vector<std::vector<Aabb>> frames = {
      {{{0, 0, 0}, {1, 1, 1}}, {{1, 1, 1}, {2, 2, 2}}, {{5, 5, 5}, {6, 7, 8}}},
      {{{0.5f, 0, 0}, {1.5f, 1, 1}}, {{1, 1, 1}, {2, 2, 2}}, {{-6, -7, -8}, {-5, -5, -5}}}};
  const auto file = path("handmade.aabbs");
  write_bytes(file, broadmark_file(frames, world));
  SceneReader r(file);
  EXPECT_EQ(r.info().format, SceneFormat::Broadmark);
  EXPECT_EQ(r.info().name, "Brownian Cubes");
  EXPECT_EQ(r.info().objects_type, "Cubes");
  EXPECT_EQ(r.info().object_count, 3u);
  EXPECT_EQ(r.info().frame_count, 2u);
  EXPECT_EQ(r.info().world.min[1], -500.0f);
  EXPECT_EQ(r.info().world.max[2], 500.0f);
  BoxArray b;
  for (std::uint32_t k = 0; k < 2; ++k) {
    r.read_frame(k, b);
    for (std::uint32_t i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(b.min(a)[i], frames[k][i].min[a]) << "frame " << k << " object " << i;
        EXPECT_EQ(b.max(a)[i], frames[k][i].max[a]) << "frame " << k << " object " << i;
      }
  }
  // Frame 0: boxes 0 and 1 touch at a corner (closed intervals).
  r.read_frame(0, b);
  EXPECT_EQ(hbp::brute_force_pairs(b), (std::vector<hbp::Pair>{{0, 1}}));
}

TEST_F(SceneFileTest, OurBroadmarkWriterProducesTheSameBytes) {
  const Aabb world{{-500, -500, -500}, {500, 500, 500}};
  const std::vector<std::vector<Aabb>> frames = {{{{0, 0, 0}, {1, 1, 1}}, {{1, 1, 1}, {2, 2, 2}}},
                                                 {{{3, 2, 1}, {4, 4, 4}}, {{-1, -2, -3}, {0, 0, 0}}}};
  const auto file = path("ours.aabbs");
  {
    SceneWriter w(file, SceneFormat::Broadmark, 2, world, "Brownian Cubes", "Cubes");
    for (const auto& f : frames) {
      BoxArray b;
      for (const auto& box : f) b.push_back(box);
      w.write_frame(b);
    }
    w.close();
  }
  EXPECT_EQ(read_bytes(file), broadmark_file(frames, world));
}

TEST_F(SceneFileTest, NativeHeaderLayoutIsAsDocumented) {
  const auto file = path("layout.hbps");
  write_scene(file, SceneFormat::Native, 3, 2, "name", "types");
  const auto bytes = read_bytes(file);
  ASSERT_EQ(bytes.size(), 320u + 2u * 3u * 24u);
  EXPECT_EQ(0, std::memcmp(bytes.data(), "HBPSCENE", 8));
  EXPECT_EQ(peek<std::uint32_t>(bytes, 8), 1u);
  EXPECT_EQ(peek<std::uint32_t>(bytes, 12), 320u);
  EXPECT_EQ(peek<std::uint32_t>(bytes, 16), 3u);
  EXPECT_EQ(peek<std::uint32_t>(bytes, 20), 2u);
  EXPECT_EQ(peek<float>(bytes, 24), -100.0f);
  EXPECT_EQ(peek<float>(bytes, 40), 50.0f);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(bytes.data() + 64)), "name");
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(bytes.data() + 192)), "types");
  // Frame 1, lane max y (lane 4), object 2.
  EXPECT_EQ(peek<float>(bytes, 320 + 1 * 3 * 24 + 4 * 3 * 4 + 2 * 4), encoded_box(1, 2).max[1]);
}

// ---- Corrupt files -----------------------------------------------------------

TEST_F(SceneFileTest, TruncatedFilesSayHowManyFramesAreComplete) {
  for (auto format : {SceneFormat::Native, SceneFormat::Broadmark}) {
    const auto file = path(std::string("trunc.") + hbp::scene_format_name(format));
    write_scene(file, format, 100, 4);
    fs::resize_file(file, fs::file_size(file) - 10);
    expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "header says 100 objects x 4 frames", "truncated: 3 complete frames"});
    fs::resize_file(file, 100);  // inside the header
    expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file});
  }
}

TEST_F(SceneFileTest, TrailingBytesAreReported) {
  for (auto format : {SceneFormat::Native, SceneFormat::Broadmark}) {
    const auto file = path(std::string("trail.") + hbp::scene_format_name(format));
    write_scene(file, format, 10, 2);
    auto bytes = read_bytes(file);
    bytes.resize(bytes.size() + 32, 0);
    write_bytes(file, bytes);
    expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "trailing data"});
  }
}

TEST_F(SceneFileTest, CountsDisagreeingWithTheSize) {
  const auto native = path("count.hbps"), broadmark = path("count.aabbs");
  write_scene(native, SceneFormat::Native, 10, 3);
  write_scene(broadmark, SceneFormat::Broadmark, 10, 3);
  auto n = read_bytes(native);
  poke<std::uint32_t>(n, 16, 11);  // object count
  write_bytes(native, n);
  expect_error<hbp::FileError>([&] { SceneReader r(native); }, {native, "11 objects x 3 frames"});
  auto b = read_bytes(broadmark);
  poke<std::int32_t>(b, 260, 5);  // numberOfFrames
  write_bytes(broadmark, b);
  expect_error<hbp::FileError>([&] { SceneReader r(broadmark); }, {broadmark, "10 objects x 6 frames"});
  // A count so large the product overflows 64 bits must not wrap to a match.
  poke<std::int32_t>(b, 256, 0x7FFFFFFF);
  poke<std::int32_t>(b, 260, 0x7FFFFFFF);
  write_bytes(broadmark, b);
  expect_error<hbp::FileError>([&] { SceneReader r(broadmark); }, {broadmark, "but the file has"});
}

TEST_F(SceneFileTest, WrongMagicAndVersion) {
  const auto file = path("magic.hbps");
  write_scene(file, SceneFormat::Native, 10, 1);
  const auto good = read_bytes(file);
  auto bytes = good;
  bytes[7] = 'X';
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "wrong magic \"HBPSCENX\""});
  expect_error<hbp::FileError>([&] { (void)hbp::detect_scene_format(file); }, {"wrong magic"});
  bytes = good;
  bytes[0] = 'Q';  // no longer recognisable as ours
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "not a scene file", "HBPSCENE"});
  bytes = good;
  poke<std::uint32_t>(bytes, 8, 2);
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "unsupported native scene version 2"});
  bytes = good;
  poke<std::uint32_t>(bytes, 12, 512);
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "header size 512"});
  // Bytes 48-51 are the frame layout (0: structure of arrays, the only one
  // version 1 has): a 1 there is an unknown layout, not a reserved byte.
  bytes = good;
  poke<std::uint32_t>(bytes, 48, 1);
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "unsupported native frame layout 1 ", "48-51"});
  bytes = good;
  bytes[50] = 1;
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "frame layout 65536"});
  for (const std::size_t reserved : {52u, 55u, 56u, 63u}) {
    bytes = good;
    bytes[reserved] = 1;
    write_bytes(file, bytes);
    expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "reserved bytes 52-63 are not 0"});
  }
}

TEST_F(SceneFileTest, FilesThatAreNotScenes) {
  const auto empty = path("empty"), junk = path("junk"), missing = path("missing");
  write_bytes(empty, {});
  std::vector<unsigned char> text(400, 'a');  // names without a terminator
  write_bytes(junk, text);
  expect_error<hbp::FileError>([&] { SceneReader r(empty); }, {empty, "empty file"});
  expect_error<hbp::FileError>([&] { SceneReader r(junk); }, {junk, "not a scene file", "sceneName is not NUL-terminated"});
  expect_error<hbp::FileError>([&] { SceneReader r(missing); }, {missing, "cannot open"});
  expect_error<hbp::FileError>([&] { (void)hbp::detect_scene_format(missing); }, {missing, "cannot open"});
}

TEST_F(SceneFileTest, BroadmarkHeaderChecksMirrorBroadmarksAssertions) {
  const auto file = path("hdr.aabbs");
  write_scene(file, SceneFormat::Broadmark, 10, 2);
  const auto good = read_bytes(file);
  auto corrupt = [&](std::size_t offset, std::int32_t value, const std::string& expected) {
    auto bytes = good;
    poke<std::int32_t>(bytes, offset, value);
    write_bytes(file, bytes);
    expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, expected});
  };
  corrupt(264, 1, "padding1/padding2 are not 0");
  corrupt(268, -1, "padding1/padding2 are not 0");
  corrupt(256, 0, "numberOfObjects is not positive");
  corrupt(256, -5, "numberOfObjects is not positive");
  corrupt(260, -7, "numberOfFrames is negative");
  corrupt(272 + 12, 0x3f800000, "worldAabb's 4th components are not 0");
  auto bytes = good;
  std::memset(bytes.data() + 128, 'x', 128);
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {"objectsType is not NUL-terminated"});
}

TEST_F(SceneFileTest, BadWorldBounds) {
  const auto file = path("world.aabbs");
  write_scene(file, SceneFormat::Broadmark, 10, 2);
  auto bytes = read_bytes(file);
  poke<float>(bytes, 272, 1000.0f);  // min x > max x
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "world bounds", "min > max"});
  poke<float>(bytes, 272, std::numeric_limits<float>::quiet_NaN());
  write_bytes(file, bytes);
  expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "world bounds", "NaN"});
}

// Corrupts one coordinate of object `object` in frame `frame` on disk.
void corrupt_coordinate(const std::string& file, SceneFormat format, std::uint32_t n, std::uint32_t frame,
                        std::uint32_t object, int lane, float value) {
  auto bytes = read_bytes(file);
  std::size_t at = 0;
  if (format == SceneFormat::Native)
    at = 320 + std::size_t{frame} * n * 24 + std::size_t(lane) * n * 4 + std::size_t{object} * 4;
  else
    at = 304 + (std::size_t{frame} * n + object) * 32 + (lane < 3 ? lane : lane + 1) * 4;
  poke<float>(bytes, at, value);
  write_bytes(file, bytes);
}

TEST_F(SceneFileTest, BadCoordinatesNameFileFrameObjectAndAxis) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  struct Case {
    int lane;
    float value;
    const char* defect;
    const char* axis;
  };
  const Case cases[] = {{1, nan, "NaN coordinate", "axis y"},
                        {5, -inf, "infinite coordinate", "axis z"},
                        {0, 1e6f, "min > max", "axis x"}};
  for (auto format : {SceneFormat::Native, SceneFormat::Broadmark}) {
    for (const auto& c : cases) {
      const auto file = path(std::string("coord.") + hbp::scene_format_name(format));
      write_scene(file, format, 50, 3);
      corrupt_coordinate(file, format, 50, 2, 37, c.lane, c.value);
      SceneReader r(file);  // the header is fine
      BoxArray b;
      r.read_frame(1, b);  // and so are the other frames
      expect_error<hbp::InvalidInput>([&] { r.read_frame(2, b); },
                                      {file, "frame 2", "object 37", c.defect, c.axis});
    }
  }
}

TEST_F(SceneFileTest, BroadmarkRecordsWithNonZeroFourthComponent) {
  const auto file = path("w.aabbs");
  write_scene(file, SceneFormat::Broadmark, 9000, 2);  // object in the second chunk
  auto bytes = read_bytes(file);
  poke<float>(bytes, 304 + (9000 + 8500) * 32 + 28, 2.0f);  // frame 1, object 8500, max.w
  write_bytes(file, bytes);
  SceneReader r(file);
  BoxArray b;
  r.read_frame(0, b);
  expect_error<hbp::FileError>([&] { r.read_frame(1, b); }, {file, "frame 1", "object 8500", "max corner is 2.0"});
}

TEST_F(SceneFileTest, FrameOutOfRange) {
  const auto file = path("range.hbps");
  write_scene(file, SceneFormat::Native, 5, 5);
  SceneReader r(file);
  BoxArray b;
  expect_error<hbp::InvalidInput>([&] { r.read_frame(9, b); }, {file, "frame 9 does not exist", "0..4"});
}

TEST_F(SceneFileTest, FileShrinkingWhileOpenIsAShortRead) {
  const auto file = path("shrink.hbps");
  write_scene(file, SceneFormat::Native, 100, 5);
  SceneReader r(file);
  fs::resize_file(file, 320 + 3 * 100 * 24 + 50);
  BoxArray b;
  r.read_frame(2, b);
  expect_error<hbp::FileError>([&] { r.read_frame(3, b); }, {file, "frame 3", "short read"});
  expect_error<hbp::FileError>([&] { r.read_frame(4, b); }, {file, "frame 4", "short read"});
}

// ---- Writer behaviour --------------------------------------------------------

TEST_F(SceneFileTest, UnfinishedFilesAreRefused) {
  for (auto format : {SceneFormat::Native, SceneFormat::Broadmark}) {
    const auto file = path(std::string("unfinished.") + hbp::scene_format_name(format));
    try {
      SceneWriter w(file, format, 10, kWorld);
      w.write_frame(encoded_frame(0, 10));
      w.write_frame(encoded_frame(1, 10));
      throw std::runtime_error("generator failed");  // the writer unwinds
    } catch (const std::runtime_error&) {
    }
    expect_error<hbp::FileError>([&] { SceneReader r(file); }, {file, "was not finished", "2 complete frames"});
  }
}

TEST_F(SceneFileTest, DestructorFinishesAFileThatWasNotClosed) {
  const auto file = path("dtor.hbps");
  {
    SceneWriter w(file, SceneFormat::Native, 10, kWorld);
    w.write_frame(encoded_frame(0, 10));
    EXPECT_EQ(w.frames_written(), 1u);
  }
  SceneReader r(file);
  EXPECT_EQ(r.info().frame_count, 1u);
}

TEST_F(SceneFileTest, WriterRejectsBadFramesWithoutWritingThem) {
  const auto file = path("reject.hbps");
  SceneWriter w(file, SceneFormat::Native, 10, kWorld);
  w.write_frame(encoded_frame(0, 10));
  expect_error<hbp::InvalidInput>([&] { w.write_frame(encoded_frame(1, 9)); }, {file, "frame 1", "9 boxes", "10 objects"});
  BoxArray bad = encoded_frame(1, 10);
  bad.max(2)[6] = std::numeric_limits<float>::quiet_NaN();
  expect_error<hbp::InvalidInput>([&] { w.write_frame(bad); }, {file, "frame 1", "object 6", "NaN", "axis z"});
  w.write_frame(encoded_frame(1, 10));
  w.close();
  w.close();  // closing twice is harmless
  expect_error<hbp::Error>([&] { w.write_frame(encoded_frame(2, 10)); }, {"already closed"});
  SceneReader r(file);
  EXPECT_EQ(r.info().frame_count, 2u);
  BoxArray b;
  r.read_frame(1, b);
  expect_same_boxes(encoded_frame(1, 10), b, "frame 1");
}

TEST_F(SceneFileTest, WriterArgumentErrors) {
  const auto file = path("args.aabbs");
  expect_error<hbp::InvalidInput>([&] { SceneWriter w(file, SceneFormat::Broadmark, 0, kWorld); }, {"at least one object"});
  expect_error<hbp::InvalidInput>([&] { SceneWriter w(file, SceneFormat::Broadmark, 0x80000000u, kWorld); }, {"int32"});
  expect_error<hbp::InvalidInput>([&] { SceneWriter w(file, SceneFormat::Native, 1, kWorld, std::string(128, 'n')); },
                                  {"longer than 127 bytes"});
  const Aabb inverted{{1, 0, 0}, {0, 1, 1}};
  expect_error<hbp::InvalidInput>([&] { SceneWriter w(file, SceneFormat::Native, 1, inverted); }, {"world bounds", "min > max"});
  expect_error<hbp::FileError>(
      [&] { SceneWriter w((fs::path(file) / "no" / "dir.hbps").string(), SceneFormat::Native, 1, kWorld); },
      {"cannot create"});
  // A Broadmark scene needs its initial frame.
  expect_error<hbp::InvalidInput>(
      [&] {
        SceneWriter w(file, SceneFormat::Broadmark, 3, kWorld);
        w.close();
      },
      {"at least one frame"});
}

TEST(SceneFormatNames, ParseAndName) {
  EXPECT_EQ(hbp::parse_scene_format("native"), SceneFormat::Native);
  EXPECT_EQ(hbp::parse_scene_format("broadmark"), SceneFormat::Broadmark);
  EXPECT_STREQ(hbp::scene_format_name(SceneFormat::Broadmark), "broadmark");
  expect_error<hbp::InvalidInput>([] { (void)hbp::parse_scene_format("json"); }, {"'json'", "native or broadmark"});
  EXPECT_EQ(hbp::scene_file_bytes(SceneFormat::Native, 1'000'000, 1000), 320ull + 24'000'000'000ull);
  EXPECT_EQ(hbp::scene_file_bytes(SceneFormat::Broadmark, 1'000'000, 1001), 304ull + 32'032'000'000ull);
}

// ---- Streaming ---------------------------------------------------------------

std::size_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

TEST_F(SceneFileTest, StreamingKeepsOneFrameInMemory) {
  // 48 MB of frames through a writer and a reader whose memory grows by
  // about one frame (1.2 MB), not by the file.
  constexpr std::uint32_t n = 50'000, frames = 40;
  const auto file = path("stream.hbps");
  BoxArray frame = encoded_frame(0, n);
  const std::size_t before = resident_bytes();
  {
    SceneWriter w(file, SceneFormat::Native, n, kWorld);
    for (std::uint32_t k = 0; k < frames; ++k) {
      frame.min(0)[k] = -static_cast<float>(k) - 1;  // frame k differs from frame k - 1 at object k
      w.write_frame(frame);
    }
    w.close();
  }
  SceneReader r(file);
  BoxArray got;
  for (std::uint32_t k = frames; k-- > 0;) {
    r.read_frame(k, got);
    EXPECT_EQ(got.min(0)[k], -static_cast<float>(k) - 1) << "frame " << k;
    EXPECT_EQ(got.min(0)[k + 1], encoded_box(0, k + 1).min[0]) << "frame " << k;
  }
  const std::size_t grown = resident_bytes() - std::min(before, resident_bytes());
  EXPECT_EQ(fs::file_size(file), hbp::scene_file_bytes(SceneFormat::Native, n, frames));
  EXPECT_LT(grown, 12u << 20) << "resident memory grew by " << grown << " bytes for a "
                              << fs::file_size(file) << "-byte scene";
}

// ---- Must show: a paper scene's pairs survive both formats -----------------

TEST_F(SceneFileTest, PaperScenePairsAreIdenticalAfterBothFormats) {
  hbp::ScenarioParams params;
  params.n = 10'000;
  params.seed = 7;
  hbp::Scenario scenario(params);
  std::vector<BoxArray> frames(2);
  std::vector<std::vector<hbp::Pair>> expected;
  for (auto& f : frames) {
    scenario.compute_boxes(f);
    scenario.step();
    expected.push_back(hbp::brute_force_pairs(f));
    ASSERT_GT(expected.back().size(), 1000u);  // a paper scene collides a lot
  }
  for (auto format : {SceneFormat::Native, SceneFormat::Broadmark}) {
    const auto file = path(std::string("paper.") + hbp::scene_format_name(format));
    {
      SceneWriter w(file, format, params.n, scenario.world_bounds(), "paper", "sphere/cuboid/cylinder/cone");
      for (const auto& f : frames) w.write_frame(f);
      w.close();
    }
    SceneReader r(file);
    ASSERT_EQ(r.info().frame_count, 2u);
    BoxArray got;
    for (std::uint32_t k = 0; k < frames.size(); ++k) {
      r.read_frame(k, got);
      const auto diff = hbp::diff_pairs(expected[k], hbp::brute_force_pairs(got));
      EXPECT_TRUE(diff.empty()) << hbp::scene_format_name(format) << " frame " << k << ": " << diff.summary();
      expect_same_boxes(frames[k], got, "frame " + std::to_string(k));
    }
  }
}

}  // namespace
