// SPDX-License-Identifier: MIT
// The GPU frame's kernels run by the CPU launcher (Launcher::Host) and the
// "cuda-host" cell engine, against the brute-force oracle frame by frame on
// every scenario kind and the adversarial scenes, with 1 and 2 threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "cuda/lbvh_bodies.hpp"
#include "cuda_test_scenes.hpp"
#include "dedup/ownership.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/cell_engine.hpp"
#include "hbp/cuda/axis_sweep.hpp"
#include "hbp/cuda/cuda_engines.hpp"
#include "hbp/cuda/frame_broadphase.hpp"
#include "hbp/cuda/lbvh.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"

namespace hbp {
namespace {

using cuda_test::lanes_of;

const ScenarioKind kKinds[] = {ScenarioKind::Paper, ScenarioKind::Clustered, ScenarioKind::Flat, ScenarioKind::Huge,
                               ScenarioKind::Degenerate};

cuda::FrameBroadPhase host_frame(unsigned threads, bool sorted = true, std::uint64_t max_pairs = 0,
                                 cuda::CellShape shape = cuda::CellShape::Columns) {
  cuda::FrameOptions o;
  o.launcher = cuda::Launcher::Host;
  o.threads = threads;
  o.sorted = sorted;
  o.max_pairs = max_pairs;
  o.cell_shape = shape;
  return cuda::FrameBroadPhase(o);
}

// The ownership rule the kernels share with the CPU is one constexpr
// function: evaluated at compile time here, on the device in the kernels.
static_assert(dedup::owns(CellRegion{{0, 0, 0}, {1, 1, 1}}, 0.5f, -3, 0, 0.25f, 0.5f, 0.5f));
static_assert(!dedup::owns(CellRegion{{0, 0, 0}, {1, 1, 1}}, 1.0f, 0, 0, 0, 0, 0));  // hi is open
static_assert(dedup::owns_sorted_x(CellRegion{{0, 0, 0}, {1, 1, 1}}, 0, 0, 0, 0.9f, 0.9f));

// Sorted output equals the oracle's list; the unsorted (frame order) list is
// canonical, duplicate-free and the same set; and both are identical for 1
// and 2 threads.
void expect_exact(const BoxArray& boxes, const std::string& what) {
  const std::vector<Pair> expected = brute_force_pairs(boxes);
  std::vector<Pair> frame_order[2];
  for (unsigned threads : {1u, 2u}) {
    auto sorted = host_frame(threads);
    ASSERT_EQ(sorted.update(lanes_of(boxes)), expected) << what << " threads " << threads;
    EXPECT_EQ(sorted.info().pairs, expected.size());
    auto unsorted = host_frame(threads, false);
    frame_order[threads - 1] = unsorted.update(lanes_of(boxes));
    for (const Pair& p : frame_order[threads - 1]) ASSERT_LT(p.a, p.b) << what;
    std::vector<Pair> copy = frame_order[threads - 1];
    std::sort(copy.begin(), copy.end());
    ASSERT_EQ(copy, expected) << what << " threads " << threads << " (frame order)";
  }
  EXPECT_EQ(frame_order[0], frame_order[1]) << what << ": order differs between 1 and 2 threads";
}

TEST(CudaHostFrame, EveryScenarioKindFrameByFrame) {
  for (ScenarioKind kind : kKinds) {
    const auto frames = cuda_test::scenario_frames(kind, 3000, 3);
    // One kept frame object across the frames: the grid kept, buffers reused.
    for (unsigned threads : {1u, 2u}) {
      auto kept = host_frame(threads);
      for (std::size_t f = 0; f < frames.size(); ++f) {
        const std::vector<Pair> expected = brute_force_pairs(frames[f]);
        ASSERT_EQ(kept.update(lanes_of(frames[f])), expected)
            << scenario_kind_name(kind) << " frame " << f << " threads " << threads;
      }
      EXPECT_GT(kept.info().cells, 1u) << scenario_kind_name(kind);
    }
    expect_exact(frames[0], scenario_kind_name(kind));
  }
}

TEST(CudaHostFrame, PaperSceneHasPairsAndKeepsItsGrid) {
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 5000, 4);
  auto f = host_frame(2);
  f.update(lanes_of(frames[0]));
  EXPECT_TRUE(f.info().replanned);
  EXPECT_GT(f.info().pairs, 100u);
  EXPECT_EQ(f.info().large, 0u);
  for (std::size_t i = 1; i < frames.size(); ++i) {
    f.update(lanes_of(frames[i]));
    EXPECT_FALSE(f.info().replanned) << "frame " << i;
    EXPECT_EQ(f.info().allocations, 0u) << "frame " << i << ": a steady frame allocated";
  }
}

TEST(CudaHostFrame, FlatSceneGetsATwoDimensionalGridOfCellsAsWideAsItsBoxes) {
  // All boxes straddle one plane: the thin axis is not cut, and cells are
  // no narrower than the boxes, so no box is large and replication is low.
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Flat, 20000, 2);
  auto f = host_frame(2);
  for (const BoxArray& boxes : frames) {
    EXPECT_EQ(f.update(lanes_of(boxes)), brute_force_pairs(boxes));
    EXPECT_EQ(f.info().grid[2], 1u);
    EXPECT_GT(f.info().grid[0], 4u);
    EXPECT_EQ(f.info().large, 0u);
    EXPECT_LT(f.info().references, 4u * 20000);
  }
}

cuda::FrameBroadPhase shaped_frame(cuda::CellShape shape, unsigned threads, bool sorted) {
  return host_frame(threads, sorted, 0, shape);
}

TEST(CudaHostFrame, EitherCellShapeFrameByFrame) {
  for (ScenarioKind kind : kKinds) {
    const auto frames = cuda_test::scenario_frames(kind, 3000, 2);
    for (const cuda::CellShape shape : {cuda::CellShape::Columns, cuda::CellShape::Cubes}) {
      std::vector<Pair> frame_order[2];
      for (unsigned threads : {1u, 2u}) {
        auto sorted = shaped_frame(shape, threads, true);
        for (std::size_t f = 0; f < frames.size(); ++f)
          ASSERT_EQ(sorted.update(lanes_of(frames[f])), brute_force_pairs(frames[f]))
              << scenario_kind_name(kind) << " shape " << int(shape) << " frame " << f << " threads " << threads;
        auto unsorted = shaped_frame(shape, threads, false);
        frame_order[threads - 1] = unsorted.update(lanes_of(frames[0]));
      }
      EXPECT_EQ(frame_order[0], frame_order[1]) << scenario_kind_name(kind) << " shape " << int(shape);
    }
  }
}

TEST(CudaHostFrame, ColumnCellsAreLongOnTheSweepAxis) {
  // Columns cut y and z more finely than cubes and x more coarsely, for
  // about a quarter of the cells; cubes cut the three axes of the paper's
  // cubic world alike.
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 20000, 1);
  auto columns = shaped_frame(cuda::CellShape::Columns, 2, true);
  auto cubes = shaped_frame(cuda::CellShape::Cubes, 2, true);
  ASSERT_EQ(columns.update(lanes_of(frames[0])), cubes.update(lanes_of(frames[0])));
  const std::uint32_t* c = columns.info().grid;
  const std::uint32_t* q = cubes.info().grid;
  EXPECT_EQ(q[0], q[1]);
  EXPECT_EQ(q[1], q[2]);
  EXPECT_LT(2 * c[0], q[0]);
  EXPECT_GT(c[1], q[1]);
  EXPECT_GT(c[2], q[2]);
  const double column_cells = double(c[0]) * c[1] * c[2], cube_cells = double(q[0]) * q[1] * q[2];
  EXPECT_GT(column_cells, cube_cells / 8);
  EXPECT_LT(column_cells, cube_cells / 2);
  EXPECT_EQ(columns.info().large, 0u);
}

TEST(CudaHostFrame, ColumnCellsStayWiderThanAFewWideBoxes) {
  // One box in a hundred is six times wider on y and z: narrower columns
  // would put each in more than kMaxRefsPerBox cells (the large pass, a
  // test against every box), so the columns stay wider than they are.
  const BoxArray boxes = cuda_test::wide_tail(20000, 100, 100, 6);
  auto columns = shaped_frame(cuda::CellShape::Columns, 2, true);
  EXPECT_EQ(columns.update(lanes_of(boxes)), brute_force_pairs(boxes));
  EXPECT_EQ(columns.info().large, 0u);
  EXPECT_LT(columns.info().grid[0], columns.info().grid[1]);
}

TEST(CudaHostFrame, ReserveProvisionsTheFirstFrame) {
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 20000, 2);
  auto cold = host_frame(2);
  auto reserved = host_frame(2);
  reserved.reserve(20000);
  EXPECT_TRUE(reserved.pairs().empty());
  EXPECT_EQ(reserved.info().allocations, 0u);
  for (const BoxArray& boxes : frames) {
    EXPECT_EQ(reserved.update(lanes_of(boxes)), cold.update(lanes_of(boxes)));
    EXPECT_EQ(reserved.info().pairs, cold.info().pairs);
  }
  auto again = host_frame(2);
  again.update(lanes_of(frames[0]));
  auto provisioned = host_frame(2);
  provisioned.reserve(20000);
  provisioned.update(lanes_of(frames[0]));
  EXPECT_LT(provisioned.info().allocations, again.info().allocations);
  EXPECT_THROW(provisioned.reserve((1u << 28) + 1), InvalidInput);
  // Any max_pairs, however small, leaves reserve to provision (the device
  // launcher's warm-up frame is not held to it) and still holds after.
  auto limited = host_frame(1, true, 2);
  EXPECT_NO_THROW(limited.reserve(1000));
  EXPECT_THROW(limited.update(lanes_of(cuda_test::all_on_one_point(3))), CapacityExceeded);
  EXPECT_EQ(limited.update(lanes_of(cuda_test::all_on_one_point(2))).size(), 1u);
}

TEST(CudaHostFrame, HugeSceneSendsTheHugeObjectsToTheLargePass) {
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Huge, 3000, 1);
  auto f = host_frame(1);
  EXPECT_EQ(f.update(lanes_of(frames[0])), brute_force_pairs(frames[0]));
  EXPECT_GE(f.info().large, 1u);
}

TEST(CudaHostFrame, AllObjectsOnOnePoint) {
  const BoxArray boxes = cuda_test::all_on_one_point(1500);
  auto f = host_frame(2);
  const auto& pairs = f.update(lanes_of(boxes));
  EXPECT_EQ(pairs.size(), 1500u * 1499u / 2);
  EXPECT_EQ(pairs, brute_force_pairs(boxes));
  expect_exact(boxes, "one point");
}

TEST(CudaHostFrame, BoxesSpanningTheWorld) {
  // A few spanning boxes among many small ones go to the large pass; the
  // grid's cells stay as wide as the small boxes, not the spanning ones.
  const BoxArray boxes = cuda_test::spanning_world(12, 1200);
  auto f = host_frame(2);
  EXPECT_EQ(f.update(lanes_of(boxes)), brute_force_pairs(boxes));
  EXPECT_EQ(f.info().large, 12u);
  EXPECT_GT(f.info().cells, 8u);
  expect_exact(boxes, "spanning the world");
  // A quarter spanning: the cells widen to them (no large pass), still exact.
  expect_exact(cuda_test::spanning_world(300, 1200), "a quarter spanning the world");
  expect_exact(cuda_test::spanning_world(400, 0), "only spanning boxes");
}

TEST(CudaHostFrame, EmptyAndSingleFrames) {
  auto f = host_frame(2);
  BoxArray none;
  EXPECT_TRUE(f.update(lanes_of(none)).empty());
  BoxArray one(1);
  one.set(0, Aabb{{0, 0, 0}, {1, 1, 1}});
  EXPECT_TRUE(f.update(lanes_of(one)).empty());
  BoxArray two(2);
  two.set(0, Aabb{{0, 0, 0}, {1, 1, 1}});
  two.set(1, Aabb{{1, 1, 1}, {2, 2, 2}});  // touching corners: closed intervals overlap
  EXPECT_EQ(f.update(lanes_of(two)), (std::vector<Pair>{Pair{0, 1}}));
}

TEST(CudaHostFrame, PairExplosionAgainstMaxPairs) {
  const BoxArray boxes = cuda_test::all_on_one_point(2000);  // 1,999,000 pairs
  auto limited = host_frame(2, true, 1'000'000);
  EXPECT_NE(cuda_test::capacity_message(limited, boxes).find("max_pairs = 1000000"), std::string::npos);
  // Exactly at the limit: no error, every pair.
  auto exact = host_frame(1, true, 1'999'000);
  EXPECT_EQ(exact.update(lanes_of(boxes)).size(), 1'999'000u);
  // The same frame object recovers on a smaller scene.
  const BoxArray small = cuda_test::all_on_one_point(100);
  EXPECT_EQ(limited.update(lanes_of(small)).size(), 4950u);
}

// The adversarial count, 10^8 pairs against max_pairs: counted
// exactly, named in the error, and the frame recovers.
TEST(CudaHostFrame, HundredMillionPairsAgainstMaxPairs) {
  const BoxArray boxes = cuda_test::all_on_one_point(cuda_test::kHundredMillionPairsOnOnePoint);
  auto limited = host_frame(2, true, 100'000'000);
  const std::string message = cuda_test::capacity_message(limited, boxes);
  EXPECT_NE(message.find("max_pairs = 100000000"), std::string::npos) << message;
  EXPECT_NE(message.find("counted 100005153"), std::string::npos) << message;
  const BoxArray small = cuda_test::all_on_one_point(100);
  EXPECT_EQ(limited.update(lanes_of(small)).size(), 4950u);
}

TEST(CudaHostFrame, RejectsDefectiveBoxesNamingTheObject) {
  BoxArray boxes = cuda_test::all_on_one_point(10);
  boxes.min(1)[7] = 5.0f;  // min > max on y
  auto f = host_frame(2);
  try {
    f.update(lanes_of(boxes));
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("object 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("min > max on y"), std::string::npos) << e.what();
  }
  boxes = cuda_test::all_on_one_point(10);
  boxes.max(2)[3] = __builtin_nanf("");
  EXPECT_THROW(f.update(lanes_of(boxes)), InvalidInput);
  EXPECT_THROW(cuda::FrameBroadPhase(cuda::FrameOptions{cuda::Launcher::Host, 0}), InvalidInput);
}

TEST(CudaHostFrame, DeviceEntriesNeedTheDeviceLauncher) {
  cuda::FrameBroadPhase f(cuda::FrameOptions{cuda::Launcher::Host, 1});
  const float one[6] = {0, 0, 0, 1, 1, 1};
  cuda::DeviceRows rows;
  rows.data = one;
  rows.n = 1;
  try {
    f.update_device(rows);
    FAIL() << "the host launcher took device rows";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("needs Launcher::Device"), std::string::npos) << e.what();
  }
  cuda::Lanes lanes;
  EXPECT_THROW(f.update_device(lanes), InvalidInput);
  rows.data = nullptr;
  EXPECT_THROW(f.update_device(rows), InvalidInput);  // null data for one row
  EXPECT_TRUE(f.pairs().empty());
}

// What a device entry refuses before any device work, naming it: null or
// misaligned data (a misaligned device read would end the CUDA context) and
// more objects than a frame takes.
TEST(CudaHostFrame, DeviceInputsAreCheckedBeforeAnyDeviceWork) {
  const auto message = [](const cuda::DeviceRows& rows) -> std::string {
    try {
      cuda::check_device_rows(rows);
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "";
  };
  alignas(8) static const float six[7] = {0, 0, 0, 1, 1, 1, 0};
  cuda::DeviceRows rows;
  rows.n = 1;
  rows.data = six;
  EXPECT_EQ(message(rows), "");
  rows.data = reinterpret_cast<const float*>(reinterpret_cast<const char*>(six) + 2);
  EXPECT_NE(message(rows).find("not aligned to a float"), std::string::npos) << message(rows);
  rows.data = nullptr;
  EXPECT_NE(message(rows).find("null data for 1 objects"), std::string::npos) << message(rows);
  rows.n = 0;
  EXPECT_EQ(message(rows), "");  // no rows, no data needed
  rows.data = six;
  rows.n = cuda::kMaxFrameObjects + 1;
  EXPECT_NE(message(rows).find("more than the limit 268435456"), std::string::npos) << message(rows);

  cuda::FrameBroadPhase f(cuda::FrameOptions{cuda::Launcher::Host, 1});
  const BoxArray two = cuda_test::all_on_one_point(2);
  cuda::Lanes lanes = lanes_of(two);
  lanes.hi[1] = reinterpret_cast<const float*>(reinterpret_cast<const char*>(lanes.hi[1]) + 1);
  try {
    f.update_device(lanes);
    FAIL() << "misaligned lanes taken";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("device lanes: max y"), std::string::npos) << e.what();
  }
}

// Appended pairs come in no fixed order: only a sorted frame swept a
// thread per reference may take them; any other is refused naming why.
TEST(CudaHostFrame, AppendedPairsNeedASortedPerReferenceFrame) {
  for (const bool sorted : {false, true})
    for (const cuda::CellSweep sweep : {cuda::CellSweep::PerReference, cuda::CellSweep::BlockPerCell}) {
      cuda::FrameOptions o;
      o.sorted = sorted;
      o.sweep = sweep;
      o.pair_write = cuda::PairWrite::Append;
      if (sorted && sweep == cuda::CellSweep::PerReference) {
        cuda::FrameBroadPhase f(o);  // the host launcher counts and fills either way
        const BoxArray boxes = cuda_test::scenario_frames(ScenarioKind::Clustered, 2000, 1)[0];
        EXPECT_EQ(f.update(lanes_of(boxes)), cuda_test::all_pairs(boxes));
        continue;
      }
      try {
        cuda::FrameBroadPhase f(o);
        FAIL() << "sorted " << sorted << " sweep " << int(sweep) << ": no error";
      } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("pair_write Append needs sorted pairs and CellSweep::PerReference"),
                  std::string::npos)
            << e.what();
      }
    }
}

TEST(CudaHostFrame, DeviceLauncherWithoutADeviceSaysSo) {
  if (cuda::device_available()) GTEST_SKIP() << "a CUDA device is present: " << cuda::device_name();
  cuda::FrameOptions o;
  o.launcher = cuda::Launcher::Device;
  try {
    cuda::FrameBroadPhase f(o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no CUDA device found"), std::string::npos) << e.what();
  }
}

// ---- The one-axis sort-and-sweep peer (CPU twin) -----------------------------------

TEST(CudaHostAxisSweep, EveryScenarioKindAndTheAdversarialScenes) {
  std::vector<BoxArray> scenes;
  for (ScenarioKind kind : kKinds) scenes.push_back(cuda_test::scenario_frames(kind, 3000, 1)[0]);
  scenes.push_back(cuda_test::all_on_one_point(1200));
  scenes.push_back(cuda_test::spanning_world(200, 1500));
  for (std::size_t s = 0; s < scenes.size(); ++s) {
    const std::vector<Pair> expected = brute_force_pairs(scenes[s]);
    std::vector<Pair> frame_order[2];
    for (unsigned threads : {1u, 2u}) {
      cuda::FrameOptions o;
      o.threads = threads;
      cuda::AxisSweep sorted(o);
      ASSERT_EQ(sorted.update(lanes_of(scenes[s])), expected) << "scene " << s << " threads " << threads;
      o.sorted = false;
      cuda::AxisSweep unsorted(o);
      frame_order[threads - 1] = unsorted.update(lanes_of(scenes[s]));
    }
    EXPECT_EQ(frame_order[0], frame_order[1]) << "scene " << s;
    std::sort(frame_order[0].begin(), frame_order[0].end());
    EXPECT_EQ(frame_order[0], expected) << "scene " << s;
  }
}

TEST(CudaHostAxisSweep, PicksTheAxisOfLargestVarianceAndHonoursMaxPairs) {
  BoxArray row(100);
  for (std::uint32_t i = 0; i < 100; ++i) {
    const float y = static_cast<float>(i) * 3;
    row.set(i, Aabb{{0, y, 0}, {1, y + 4, 1}});  // spread along y; neighbours overlap
  }
  cuda::FrameOptions o;
  cuda::AxisSweep sweep(o);
  EXPECT_EQ(sweep.update(lanes_of(row)), brute_force_pairs(row));
  EXPECT_EQ(sweep.axis(), 1);
  o.max_pairs = 1000;
  cuda::AxisSweep limited(o);
  EXPECT_THROW(limited.update(lanes_of(cuda_test::all_on_one_point(100))), CapacityExceeded);  // 4,950 pairs
}

// ---- The Karras-style LBVH peer (CPU twin) ----------------------------------------

cuda::Lbvh host_lbvh(unsigned threads, bool sorted = true, std::uint64_t max_pairs = 0) {
  cuda::FrameOptions o;
  o.launcher = cuda::Launcher::Host;
  o.threads = threads;
  o.sorted = sorted;
  o.max_pairs = max_pairs;
  return cuda::Lbvh(o);
}

// Sorted output equals the oracle's list; the traversal-order list is
// canonical, the same set, and identical for 1 and 2 threads.
void expect_lbvh_exact(const BoxArray& boxes, const std::string& what) {
  const std::vector<Pair> expected = brute_force_pairs(boxes);
  std::vector<Pair> traversal_order[2];
  for (unsigned threads : {1u, 2u}) {
    auto sorted = host_lbvh(threads);
    ASSERT_EQ(sorted.update(lanes_of(boxes)), expected) << what << " threads " << threads;
    EXPECT_EQ(sorted.info().pairs, expected.size()) << what;
    auto unsorted = host_lbvh(threads, false);
    traversal_order[threads - 1] = unsorted.update(lanes_of(boxes));
    for (const Pair& p : traversal_order[threads - 1]) ASSERT_LT(p.a, p.b) << what;
    std::vector<Pair> copy = traversal_order[threads - 1];
    std::sort(copy.begin(), copy.end());
    ASSERT_EQ(copy, expected) << what << " threads " << threads << " (traversal order)";
  }
  EXPECT_EQ(traversal_order[0], traversal_order[1]) << what << ": order differs between 1 and 2 threads";
}

// The radix tree of build_node over sorted unique keys: every node but the
// root has one parent, an in-order walk meets the leaves 0..n-1 once each,
// each node's `last` is its rightmost leaf, and no path is deeper than the
// traversal's stack.
void expect_radix_tree(const std::vector<std::uint64_t>& keys, const std::string& what) {
  const auto n = static_cast<std::uint32_t>(keys.size());
  ASSERT_TRUE(std::is_sorted(keys.begin(), keys.end())) << what;
  std::vector<std::uint32_t> left(n - 1), right(n - 1), last(n - 1), node_parent(n - 1, 7), leaf_parent(n, 7);
  std::vector<float> unused(6 * n);
  const cuda::LbvhNodes t{left.data(), right.data(), last.data(), node_parent.data(), leaf_parent.data(),
                          {unused.data(), unused.data(), unused.data()}, {unused.data(), unused.data(), unused.data()}};
  for (std::uint32_t i = 0; i + 1 < n; ++i) cuda::build_node(keys.data(), n, i, t);
  std::vector<std::uint32_t> leaves;
  int deepest = 0;
  // A child reference c of `parent` at `depth`; returns the rightmost leaf under c.
  auto walk = [&](auto&& self, std::uint32_t c, std::uint32_t parent, int depth) -> std::uint32_t {
    if (c & cuda::kLeafBit) {
      EXPECT_EQ(leaf_parent[c & ~cuda::kLeafBit], parent) << what;
      leaves.push_back(c & ~cuda::kLeafBit);
      return c & ~cuda::kLeafBit;
    }
    deepest = std::max(deepest, depth + 1);
    EXPECT_EQ(node_parent[c], parent) << what;
    self(self, left[c], c, depth + 1);
    const std::uint32_t rightmost = self(self, right[c], c, depth + 1);
    EXPECT_EQ(last[c], rightmost) << what << " node " << c;
    return rightmost;
  };
  walk(walk, 0, cuda::kNoParent, 0);
  ASSERT_EQ(leaves.size(), n) << what;
  for (std::uint32_t q = 0; q < n; ++q) ASSERT_EQ(leaves[q], q) << what;
  EXPECT_LE(deepest, 62) << what;
}

TEST(CudaHostLbvh, RadixTreeCoversEveryLeafOnceInOrder) {
  // Morton codes from a small alphabet (many equal codes, split by the index
  // word), all equal (one point: a balanced tree over the indices), and two.
  std::vector<std::uint64_t> keys;
  for (std::uint32_t i = 0; i < 3000; ++i) keys.push_back((std::uint64_t{(i * 7919u) % 61u * 9973u} << 32) | i);
  std::sort(keys.begin(), keys.end());
  expect_radix_tree(keys, "repeated codes");
  keys.clear();
  for (std::uint32_t i = 0; i < 1000; ++i) keys.push_back((std::uint64_t{0x2AAAAAAAu} << 32) | i);
  expect_radix_tree(keys, "one code");
  expect_radix_tree({5, 9}, "two leaves");
  // Codes at both ends of the 30-bit range with indices at both ends of 28 bits.
  expect_radix_tree({0, (std::uint64_t{0x3FFFFFFFu} << 32) | 0, (std::uint64_t{0x3FFFFFFFu} << 32) | 0x0FFFFFFFu},
                    "extreme keys");
  EXPECT_EQ(cuda::spread_bits(1023u), 0x09249249u);
  EXPECT_EQ(cuda::quantize(0.0f, 0.0f, 0.0f), 0u);  // a flat axis: 0 / 0
  EXPECT_EQ(cuda::quantize(std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                           std::numeric_limits<float>::max()),
            1023u);
  EXPECT_EQ(cuda::quantize(0.0f, -std::numeric_limits<float>::max(), std::numeric_limits<float>::max()), 512u);
}

TEST(CudaHostLbvh, EveryScenarioKindFrameByFrame) {
  for (ScenarioKind kind : kKinds) {
    const auto frames = cuda_test::scenario_frames(kind, 3000, 3);
    for (unsigned threads : {1u, 2u}) {
      auto kept = host_lbvh(threads);  // one object across the frames: buffers reused
      for (std::size_t f = 0; f < frames.size(); ++f)
        ASSERT_EQ(kept.update(lanes_of(frames[f])), brute_force_pairs(frames[f]))
            << scenario_kind_name(kind) << " frame " << f << " threads " << threads;
    }
    expect_lbvh_exact(frames[0], scenario_kind_name(kind));
  }
}

TEST(CudaHostLbvh, AllObjectsOnOnePoint) {
  // Every Morton code equal: the tree is split by the index bits alone.
  const BoxArray boxes = cuda_test::all_on_one_point(1500);
  auto lbvh = host_lbvh(2);
  EXPECT_EQ(lbvh.update(lanes_of(boxes)).size(), 1500u * 1499u / 2);
  expect_lbvh_exact(boxes, "one point");
}

TEST(CudaHostLbvh, BoxesSpanningTheWorldAndTheFloatRange) {
  expect_lbvh_exact(cuda_test::spanning_world(300, 1200), "spanning the world");
  expect_lbvh_exact(cuda_test::spanning_world(400, 0), "only spanning boxes");
  const BoxArray extreme = cuda_test::extreme_boxes(1500);
  auto lbvh = host_lbvh(1);
  const std::vector<Pair>& pairs = lbvh.update(lanes_of(extreme));
  // The two [-FLT_MAX, FLT_MAX] boxes meet every box: 2 * 1511 - 1 pairs at least.
  EXPECT_GE(pairs.size(), 2u * 1511u - 1u);
  EXPECT_EQ(pairs, brute_force_pairs(extreme));
  expect_lbvh_exact(extreme, "float range");
  expect_lbvh_exact(cuda_test::extreme_boxes(0), "float range, no small boxes");
}

TEST(CudaHostLbvh, FlatAxesAndSmallFrames) {
  // Every box on the plane z = 5: that axis has no extent to quantize in.
  BoxArray flat = cuda_test::scenario_frames(ScenarioKind::Paper, 2000, 1)[0];
  for (std::size_t i = 0; i < flat.size(); ++i) flat.min(2)[i] = flat.max(2)[i] = 5.0f;
  expect_lbvh_exact(flat, "flat on z");
  auto lbvh = host_lbvh(2);
  EXPECT_TRUE(lbvh.update(lanes_of(BoxArray{})).empty());
  EXPECT_EQ(lbvh.info().pairs, 0u);
  BoxArray one(1);
  one.set(0, Aabb{{0, 0, 0}, {1, 1, 1}});
  EXPECT_TRUE(lbvh.update(lanes_of(one)).empty());
  BoxArray two(2);
  two.set(0, Aabb{{1, 1, 1}, {2, 2, 2}});
  two.set(1, Aabb{{0, 0, 0}, {1, 1, 1}});  // touching corners: closed intervals overlap
  EXPECT_EQ(lbvh.update(lanes_of(two)), (std::vector<Pair>{Pair{0, 1}}));
  two.set(1, Aabb{{0, 0, 0}, {1, 1, 0.99f}});
  EXPECT_TRUE(lbvh.update(lanes_of(two)).empty());
  BoxArray three(3);
  for (std::uint32_t i = 0; i < 3; ++i) three.set(i, Aabb{{0, 0, 0}, {0, 0, 0}});
  EXPECT_EQ(lbvh.update(lanes_of(three)), (std::vector<Pair>{Pair{0, 1}, Pair{0, 2}, Pair{1, 2}}));
}

TEST(CudaHostLbvh, PairExplosionAgainstMaxPairs) {
  const BoxArray boxes = cuda_test::all_on_one_point(2000);  // 1,999,000 pairs
  auto limited = host_lbvh(2, true, 1'000'000);
  const std::string message = cuda_test::capacity_message(limited, boxes);
  EXPECT_NE(message.find("max_pairs = 1000000"), std::string::npos) << message;
  EXPECT_NE(message.find("counted 1999000"), std::string::npos) << message;
  auto exact = host_lbvh(1, true, 1'999'000);
  EXPECT_EQ(exact.update(lanes_of(boxes)).size(), 1'999'000u);
  EXPECT_EQ(limited.update(lanes_of(cuda_test::all_on_one_point(100))).size(), 4950u);  // recovers
}

TEST(CudaHostLbvh, RejectsDefectiveBoxesNamingTheObject) {
  BoxArray boxes = cuda_test::all_on_one_point(10);
  boxes.min(1)[7] = 5.0f;  // min > max on y
  boxes.max(0)[8] = __builtin_inff();
  auto lbvh = host_lbvh(2);
  try {
    lbvh.update(lanes_of(boxes));
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("object 7 has min > max on y"), std::string::npos) << e.what();
  }
  boxes = cuda_test::all_on_one_point(10);
  boxes.max(2)[3] = __builtin_nanf("");
  try {
    lbvh.update(lanes_of(boxes));
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("object 3 has a NaN or infinite coordinate on z"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(cuda::Lbvh(cuda::FrameOptions{cuda::Launcher::Host, 0}), InvalidInput);
}

TEST(CudaHostLbvh, SteadyFramesAllocateNothing) {
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 5000, 4);
  auto lbvh = host_lbvh(2);
  lbvh.update(lanes_of(frames[0]));
  EXPECT_GT(lbvh.info().allocations, 0u);
  EXPECT_GT(lbvh.info().pairs, 100u);
  EXPECT_GE(lbvh.info().buffer_bytes, 5000u * (6 * 4 + 8));  // sorted boxes and keys at least
  for (std::size_t f = 1; f < frames.size(); ++f) {
    EXPECT_EQ(lbvh.update(lanes_of(frames[f])), brute_force_pairs(frames[f])) << "frame " << f;
    EXPECT_EQ(lbvh.info().allocations, 0u) << "frame " << f << ": a steady frame allocated";
  }
  for (int repeat = 0; repeat < 2; ++repeat) {
    lbvh.update(lanes_of(frames[3]));
    EXPECT_EQ(lbvh.info().allocations, 0u) << "the same frame again allocated";
  }
}

TEST(CudaHostLbvh, DeviceLauncherWithoutADeviceSaysSo) {
  if (cuda::device_available()) GTEST_SKIP() << "a CUDA device is present: " << cuda::device_name();
  cuda::FrameOptions o;
  o.launcher = cuda::Launcher::Device;
  try {
    cuda::Lbvh lbvh(o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no CUDA device found"), std::string::npos) << e.what();
  }
}

// ---- The cell engines ---------------------------------------------------------

class CudaHostEngine : public ::testing::Test {
 protected:
  void SetUp() override { cuda::register_cell_engines(); }
};

TEST_F(CudaHostEngine, RegisteredAndDescribed) {
  cuda::register_cell_engines();  // idempotent
  const auto names = cell_engine_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "cuda-host"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "cuda"), names.end());
  EXPECT_EQ(make_cell_engine("cuda-host")->name(), "cuda-host");
  EXPECT_FALSE(cell_engine_description("cuda").empty());
}

TEST_F(CudaHostEngine, HybridSystemEveryScenarioKindFrameByFrame) {
  for (ScenarioKind kind : kKinds) {
    const auto frames = cuda_test::scenario_frames(kind, 3000, 3);
    std::vector<Pair> first[2];
    for (unsigned threads : {1u, 2u}) {
      BroadPhaseOptions o;
      o.engine = "cuda-host";
      o.threads = threads;
      o.cell_limit = 64;  // many cells: ownership decides many pairs
      HybridBroadPhase hybrid(o);
      for (std::size_t f = 0; f < frames.size(); ++f) {
        const std::vector<Pair>& got = hybrid.update(frames[f]);
        ASSERT_EQ(got, brute_force_pairs(frames[f]))
            << scenario_kind_name(kind) << " frame " << f << " threads " << threads;
        if (f == 0) first[threads - 1] = got;
      }
    }
    EXPECT_EQ(first[0], first[1]);
  }
}

TEST_F(CudaHostEngine, HybridSystemAdversarialScenes) {
  for (unsigned threads : {1u, 2u}) {
    BroadPhaseOptions o;
    o.engine = "cuda-host";
    o.threads = threads;
    HybridBroadPhase hybrid(o);
    const BoxArray point = cuda_test::all_on_one_point(1200);
    EXPECT_EQ(hybrid.update(point), brute_force_pairs(point));
    const BoxArray span = cuda_test::spanning_world(200, 1500);
    EXPECT_EQ(hybrid.update(span), brute_force_pairs(span));
  }
}

TEST_F(CudaHostEngine, PairLimitGivesCapacityExceeded) {
  BroadPhaseOptions o;
  o.engine = "cuda-host";
  o.threads = 2;
  o.max_pairs = 100'000;
  HybridBroadPhase hybrid(o);
  EXPECT_THROW(hybrid.update(cuda_test::all_on_one_point(1000)), CapacityExceeded);  // 499,500 pairs
  auto engine = make_cell_engine("cuda-host");
  engine->set_pair_limit(10);
  std::vector<Pair> out;
  EXPECT_THROW(engine->find_pairs(cuda_test::all_on_one_point(6), out), CapacityExceeded);  // 15 pairs
  EXPECT_TRUE(out.empty()) << "nothing is appended past the limit";
}

TEST_F(CudaHostEngine, FindPairsOnAnUnsortedCell) {
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Degenerate, 800, 1);
  auto engine = make_cell_engine("cuda-host");
  std::vector<Pair> out;
  engine->find_pairs(frames[0], out);
  std::sort(out.begin(), out.end());
  EXPECT_EQ(out, brute_force_pairs(frames[0]));
}

TEST_F(CudaHostEngine, DeviceEngineWithoutADeviceSaysSo) {
  if (cuda::device_available()) GTEST_SKIP() << "a CUDA device is present: " << cuda::device_name();
  try {
    make_cell_engine("cuda");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no CUDA device found"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hbp
