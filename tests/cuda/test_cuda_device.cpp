// SPDX-License-Identifier: MIT
// The GPU frame on a real CUDA device (ctest label "gpu"): device pairs
// identical to the CPU launcher's (same kernel bodies: same list, same order)
// and to the oracle, frame by frame on every scenario kind and the
// adversarial scenes; steady frames allocate nothing; max_pairs. Without a
// device every test SKIPS; HBP_REQUIRE_GPU=1 (set by scripts/gpu-check, the
// device machine's script) turns that skip into a failure.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <cuda_runtime.h>

#include "cuda_test_scenes.hpp"
#include "hbp/cuda/axis_sweep.hpp"
#include "hbp/cuda/frame_broadphase.hpp"
#include "hbp/cuda/lbvh.hpp"
#include "hbp/error.hpp"
#ifdef HBP_TEST_CUDA_ENGINES
#include "hbp/cell_engine.hpp"
#include "hbp/cuda/cuda_engines.hpp"
#include "hbp/hybrid_broadphase.hpp"
#endif

namespace hbp {
namespace {

using cuda_test::lanes_of;

#define REQUIRE_DEVICE()                                                                              \
  do {                                                                                                \
    if (!cuda::device_available()) {                                                                  \
      const char* required = std::getenv("HBP_REQUIRE_GPU");                                          \
      if (required && std::strcmp(required, "1") == 0) FAIL() << "HBP_REQUIRE_GPU=1 but no CUDA device"; \
      GTEST_SKIP() << "no CUDA device";                                                               \
    }                                                                                                 \
  } while (0)

const ScenarioKind kKinds[] = {ScenarioKind::Paper, ScenarioKind::Clustered, ScenarioKind::Flat, ScenarioKind::Huge,
                               ScenarioKind::Degenerate};

cuda::FrameBroadPhase frame(cuda::Launcher launcher, bool sorted = true, std::uint64_t max_pairs = 0,
                            cuda::CellSweep sweep = cuda::CellSweep::PerReference,
                            cuda::PairOrder order = cuda::PairOrder::Radix,
                            cuda::PairWrite write = cuda::PairWrite::Offsets) {
  cuda::FrameOptions o;
  o.launcher = launcher;
  o.threads = std::max(2u, std::thread::hardware_concurrency());  // the CPU launcher is the reference
  o.sorted = sorted;
  o.max_pairs = max_pairs;
  o.sweep = sweep;
  o.pair_order = order;
  o.pair_write = write;
  return cuda::FrameBroadPhase(o);
}

// One frame of every scenario kind (n objects), `on_one_point` objects on
// one point, and `spanning` of 2,000 boxes spanning the world.
std::vector<BoxArray> scenes_of_every_kind(std::uint32_t n, std::uint32_t on_one_point, std::uint32_t spanning) {
  std::vector<BoxArray> scenes;
  for (ScenarioKind kind : kKinds) scenes.push_back(cuda_test::scenario_frames(kind, n, 1)[0]);
  scenes.push_back(cuda_test::all_on_one_point(on_one_point));
  scenes.push_back(cuda_test::spanning_world(spanning, 2000));
  return scenes;
}

// Both device sweeps (a thread per reference, a block per cell) give the CPU
// launcher's list, in its order, every frame; sorted, so do the pairs
// appended in one pass and ordered through buckets.
void expect_device_matches(const std::vector<BoxArray>& frames, const std::string& what, bool oracle) {
  for (bool sorted : {true, false}) {
    auto host = frame(cuda::Launcher::Host, sorted);
    auto per_reference = frame(cuda::Launcher::Device, sorted, 0, cuda::CellSweep::PerReference);
    auto block_per_cell = frame(cuda::Launcher::Device, sorted, 0, cuda::CellSweep::BlockPerCell);
    auto appended = frame(cuda::Launcher::Device, true, 0, cuda::CellSweep::PerReference, cuda::PairOrder::Buckets,
                          cuda::PairWrite::Append);
    std::vector<cuda::FrameBroadPhase*> devices{&per_reference, &block_per_cell};
    if (sorted) devices.push_back(&appended);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const std::vector<Pair> expected = host.update(lanes_of(frames[f]));
      if (oracle && sorted) {
        ASSERT_EQ(expected, cuda_test::all_pairs(frames[f])) << what << " frame " << f;
      }
      for (cuda::FrameBroadPhase* device : devices) {
        const char* sweep = device == &per_reference    ? "per reference"
                            : device == &block_per_cell ? "block per cell"
                                                        : "appended, buckets";
        ASSERT_EQ(device->update(lanes_of(frames[f])), expected)
            << what << " frame " << f << " sorted " << sorted << " sweep " << sweep;
        EXPECT_EQ(device->info().cells, host.info().cells);
        EXPECT_EQ(device->info().large, host.info().large);
        if (f > 0) {
          EXPECT_EQ(device->info().allocations, 0u) << what << " frame " << f << " " << sweep << ": a steady frame allocated";
        }
      }
    }
  }
}

TEST(CudaDevice, EveryScenarioKindFrameByFrame) {
  REQUIRE_DEVICE();
  for (ScenarioKind kind : kKinds)
    expect_device_matches(cuda_test::scenario_frames(kind, 4000, 4), scenario_kind_name(kind), true);
}

TEST(CudaDevice, LargerScenesMatchTheCpuLauncher) {
  REQUIRE_DEVICE();
  // Degenerate stacks a third of its objects on 8 points (pairs grow as n^2):
  // 20,000 objects already give ~22 M pairs.
  for (ScenarioKind kind : kKinds)
    expect_device_matches(cuda_test::scenario_frames(kind, kind == ScenarioKind::Degenerate ? 20'000 : 200'000, 2),
                          scenario_kind_name(kind), false);
}

TEST(CudaDevice, AdversarialScenes) {
  REQUIRE_DEVICE();
  expect_device_matches({cuda_test::all_on_one_point(3000)}, "one point", true);
  expect_device_matches({cuda_test::spanning_world(300, 2000)}, "spanning the world", true);
  expect_device_matches({cuda_test::spanning_world(16, 2000)}, "a few spanning the world (large pass)", true);
  expect_device_matches({BoxArray{}}, "empty", true);
}

// Cubes as well as the default columns: the device plans the CPU
// launcher's grid and gives its list, in its order, with either sweep.
TEST(CudaDevice, EitherCellShapeMatchesTheCpuLauncher) {
  REQUIRE_DEVICE();
  std::vector<BoxArray> scenes = scenes_of_every_kind(6000, 3000, 16);
  scenes.push_back(cuda_test::wide_tail(20000, 100, 100, 6));
  for (const cuda::CellShape shape : {cuda::CellShape::Columns, cuda::CellShape::Cubes})
    for (const cuda::CellSweep sweep : {cuda::CellSweep::PerReference, cuda::CellSweep::BlockPerCell})
      for (bool sorted : {true, false}) {
        cuda::FrameOptions o;
        o.threads = std::max(2u, std::thread::hardware_concurrency());
        o.sorted = sorted;
        o.sweep = sweep;
        o.cell_shape = shape;
        cuda::FrameBroadPhase host(o);
        o.launcher = cuda::Launcher::Device;
        cuda::FrameBroadPhase device(o);
        for (std::size_t s = 0; s < scenes.size(); ++s) {
          const std::vector<Pair> expected = host.update(lanes_of(scenes[s]));
          ASSERT_EQ(device.update(lanes_of(scenes[s])), expected)
              << "scene " << s << " shape " << int(shape) << " sweep " << int(sweep) << " sorted " << sorted;
          for (int k = 0; k < 3; ++k) EXPECT_EQ(device.info().grid[k], host.info().grid[k]);
          EXPECT_EQ(device.info().large, host.info().large);
        }
      }
}

// Every pair order and write gives the oracle's list: buckets from one to
// thousands of partners (the one-point scene: one bucket per smaller id),
// appended pairs outgrowing the last frame's room (each scene larger than
// the one before) and a large pass appending too.
TEST(CudaDevice, PairOrdersAndWritesGiveOneList) {
  REQUIRE_DEVICE();
  std::vector<BoxArray> scenes = scenes_of_every_kind(6000, 3000, 16);
  scenes.push_back(BoxArray{});
  for (cuda::PairOrder order : {cuda::PairOrder::Radix, cuda::PairOrder::Buckets})
    for (cuda::PairWrite write : {cuda::PairWrite::Offsets, cuda::PairWrite::Append}) {
      cuda::FrameOptions o;
      o.launcher = cuda::Launcher::Device;
      o.pair_order = order;
      o.pair_write = write;
      cuda::FrameBroadPhase device(o);
      cuda::Lbvh lbvh(o);
      for (std::size_t s = 0; s < scenes.size(); ++s) {
        const std::vector<Pair> expected = cuda_test::all_pairs(scenes[s]);
        ASSERT_EQ(device.update(lanes_of(scenes[s])), expected)
            << "scene " << s << " order " << int(order) << " write " << int(write);
        EXPECT_EQ(device.info().pairs, expected.size());
        ASSERT_EQ(lbvh.update(lanes_of(scenes[s])), expected) << "scene " << s << " order " << int(order);
      }
      o.max_pairs = 1000;
      cuda::FrameBroadPhase limited(o);
      EXPECT_THROW(limited.update(lanes_of(cuda_test::all_on_one_point(100))), CapacityExceeded);  // 4,950 pairs
      EXPECT_EQ(limited.update(lanes_of(cuda_test::all_on_one_point(45))).size(), 990u);
    }
}

TEST(CudaDevice, PairExplosionAgainstMaxPairs) {
  REQUIRE_DEVICE();
  const BoxArray boxes = cuda_test::all_on_one_point(4000);  // 7,998,000 pairs
  auto limited = frame(cuda::Launcher::Device, true, 1'000'000);
  EXPECT_THROW(limited.update(lanes_of(boxes)), CapacityExceeded);
  auto unlimited = frame(cuda::Launcher::Device, true);
  EXPECT_EQ(unlimited.update(lanes_of(boxes)).size(), 7'998'000u);
}

// 10^8 pairs in one cell: refused against max_pairs = 10^8 with the exact
// count, and every pair there, sorted, without a limit, in every pair order
// and write.
TEST(CudaDevice, HundredMillionPairsOnOnePoint) {
  REQUIRE_DEVICE();
  const std::uint32_t n = cuda_test::kHundredMillionPairsOnOnePoint;
  const BoxArray boxes = cuda_test::all_on_one_point(n);
  auto limited = frame(cuda::Launcher::Device, true, 100'000'000);
  const std::string message = cuda_test::capacity_message(limited, boxes);
  EXPECT_NE(message.find("counted 100005153"), std::string::npos) << message;
  for (cuda::PairOrder order : {cuda::PairOrder::Radix, cuda::PairOrder::Buckets})
    for (cuda::PairWrite write : {cuda::PairWrite::Offsets, cuda::PairWrite::Append}) {
      auto unlimited = frame(cuda::Launcher::Device, true, 0, cuda::CellSweep::PerReference, order, write);
      const std::vector<Pair>& pairs = unlimited.update(lanes_of(boxes));
      EXPECT_EQ(pairs.size(), cuda_test::kHundredMillionPairs) << "order " << int(order) << " write " << int(write);
      EXPECT_EQ(cuda_test::first_pair_not_all_of(pairs, n), pairs.size())
          << "order " << int(order) << " write " << int(write);
    }
}

// The boxes as six lanes in one allocation `d` on the current device.
cuda::Lanes upload_lanes(const BoxArray& boxes, float*& d) {
  const std::size_t n = boxes.size();
  cuda::Lanes lanes;
  lanes.n = static_cast<std::uint32_t>(n);
  EXPECT_EQ(cudaMalloc(&d, 6 * n * sizeof(float)), cudaSuccess);
  for (int l = 0; l < 6; ++l) {
    const float* src = l < 3 ? boxes.min(l) : boxes.max(l - 3);
    EXPECT_EQ(cudaMemcpy(d + l * n, src, n * sizeof(float), cudaMemcpyHostToDevice), cudaSuccess);
    (l < 3 ? lanes.lo[l] : lanes.hi[l - 3]) = d + l * n;
  }
  return lanes;
}

// The pairs a device entry left in device memory, copied to the host.
std::vector<Pair> pairs_of(const cuda::DevicePairs& got) {
  std::vector<Pair> pairs(got.count);
  EXPECT_EQ(cudaMemcpy(pairs.data(), got.data, got.count * sizeof(Pair), cudaMemcpyDeviceToHost), cudaSuccess);
  return pairs;
}

TEST(CudaDevice, DeviceEntryLeavesPairsOnTheDevice) {
  REQUIRE_DEVICE();
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 20'000, 1);
  const BoxArray& boxes = frames[0];
  float* d = nullptr;
  const cuda::Lanes lanes = upload_lanes(boxes, d);
  cudaStream_t stream;
  ASSERT_EQ(cudaStreamCreate(&stream), cudaSuccess);
  auto device = frame(cuda::Launcher::Device);
  EXPECT_EQ(pairs_of(device.update_device(lanes, stream)), cuda_test::all_pairs(boxes));
  cudaStreamDestroy(stream);
  cudaFree(d);
}

// A frame keeps the device it was made on: boxes in another device's memory
// and a stream of another device are refused with both devices named, the
// caller's current device is given back, and the frame runs on its own
// device after, whichever device is current. Needs two devices.
TEST(CudaDevice, InputAndStreamOfAnotherDeviceAreRefused) {
  REQUIRE_DEVICE();
  int count = 0;
  ASSERT_EQ(cudaGetDeviceCount(&count), cudaSuccess);
  if (count < 2) GTEST_SKIP() << "needs two CUDA devices, " << count << " present";
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 5'000, 1);
  const BoxArray& boxes = frames[0];
  const std::vector<Pair> expected = cuda_test::all_pairs(boxes);
  ASSERT_EQ(cudaSetDevice(1), cudaSuccess);
  float* on_1 = nullptr;
  const cuda::Lanes lanes_1 = upload_lanes(boxes, on_1);
  cudaStream_t stream_1;
  ASSERT_EQ(cudaStreamCreate(&stream_1), cudaSuccess);
  ASSERT_EQ(cudaSetDevice(0), cudaSuccess);
  float* on_0 = nullptr;
  const cuda::Lanes lanes_0 = upload_lanes(boxes, on_0);
  auto device = frame(cuda::Launcher::Device);
  const auto refusal = [&](const cuda::Lanes& lanes, void* stream) -> std::string {
    try {
      device.update_device(lanes, stream);
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "no InvalidInput";
  };
  for (const std::string& message : {refusal(lanes_1, nullptr), refusal(lanes_0, stream_1)}) {
    EXPECT_NE(message.find("device 1"), std::string::npos) << message;
    EXPECT_NE(message.find("device 0"), std::string::npos) << message;
  }
  int current = -1;
  ASSERT_EQ(cudaGetDevice(&current), cudaSuccess);
  EXPECT_EQ(current, 0);
  EXPECT_EQ(pairs_of(device.update_device(lanes_0)), expected);
  ASSERT_EQ(cudaSetDevice(1), cudaSuccess);
  EXPECT_EQ(pairs_of(device.update_device(lanes_0)), expected);
  ASSERT_EQ(cudaGetDevice(&current), cudaSuccess);
  EXPECT_EQ(current, 1);
  cudaStreamDestroy(stream_1);
  cudaFree(on_1);
  ASSERT_EQ(cudaSetDevice(0), cudaSuccess);
  cudaFree(on_0);
}

// Rows of an (n, 6) device array, C order and Fortran order (as CuPy and
// PyTorch hand them over): the same pairs as the oracle, no host round trip.
TEST(CudaDevice, DeviceRowsInEitherOrderGiveTheOraclesPairs) {
  REQUIRE_DEVICE();
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Clustered, 20'000, 1);
  const BoxArray& boxes = frames[0];
  const std::size_t n = boxes.size();
  const std::vector<Pair> expected = cuda_test::all_pairs(boxes);
  for (bool c_order : {true, false}) {
    std::vector<float> host(6 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (int l = 0; l < 6; ++l) {
        const float v = l < 3 ? boxes.min(l)[i] : boxes.max(l - 3)[i];
        host[c_order ? 6 * i + l : l * n + i] = v;
      }
    float* d = nullptr;
    ASSERT_EQ(cudaMalloc(&d, host.size() * sizeof(float)), cudaSuccess);
    ASSERT_EQ(cudaMemcpy(d, host.data(), host.size() * sizeof(float), cudaMemcpyHostToDevice), cudaSuccess);
    cuda::DeviceRows rows;
    rows.data = d;
    rows.n = static_cast<std::uint32_t>(n);
    rows.row_stride = c_order ? 6 : 1;
    rows.column_stride = c_order ? 1 : static_cast<std::int64_t>(n);
    auto device = frame(cuda::Launcher::Device);
    EXPECT_EQ(pairs_of(device.update_device(rows)), expected) << (c_order ? "C order" : "Fortran order");
    EXPECT_GT(device.info().times.upload_ms, 0.0);
    cudaFree(d);
  }
}

TEST(CudaDevice, ReserveProvisionsTheFirstFrame) {
  REQUIRE_DEVICE();
  const auto frames = cuda_test::scenario_frames(ScenarioKind::Paper, 50'000, 2);
  auto cold = frame(cuda::Launcher::Device);
  auto reserved = frame(cuda::Launcher::Device);
  reserved.reserve(50'000);
  EXPECT_TRUE(reserved.pairs().empty());
  for (const BoxArray& boxes : frames) {
    const std::vector<Pair> expected = cold.update(lanes_of(boxes));
    EXPECT_EQ(reserved.update(lanes_of(boxes)), expected);
  }
  EXPECT_EQ(reserved.pairs(), cuda_test::all_pairs(frames.back()));
  auto again = frame(cuda::Launcher::Device);
  const std::uint64_t cold_allocations = (again.update(lanes_of(frames[0])), again.info().allocations);
  auto provisioned = frame(cuda::Launcher::Device);
  provisioned.reserve(50'000);
  provisioned.update(lanes_of(frames[0]));
  EXPECT_LT(provisioned.info().allocations, cold_allocations);
  EXPECT_LE(provisioned.info().allocations, 2u) << "reserve left most of the first frame's buffers to it";
  // reserve's own frame (three boxes, three pairs) is not held to the
  // caller's max_pairs, which still holds for the frames after it.
  auto limited = frame(cuda::Launcher::Device, true, 2);
  EXPECT_NO_THROW(limited.reserve(1000));
  EXPECT_THROW(limited.update(lanes_of(cuda_test::all_on_one_point(3))), CapacityExceeded);
  EXPECT_EQ(limited.update(lanes_of(cuda_test::all_on_one_point(2))).size(), 1u);
}

TEST(CudaDevice, AxisSweepPeerMatchesTheOracle) {
  REQUIRE_DEVICE();
  const std::vector<BoxArray> scenes = scenes_of_every_kind(4000, 2000, 300);
  cuda::FrameOptions o;
  o.launcher = cuda::Launcher::Device;
  cuda::AxisSweep sweep(o);
  for (std::size_t s = 0; s < scenes.size(); ++s)
    ASSERT_EQ(sweep.update(lanes_of(scenes[s])), cuda_test::all_pairs(scenes[s])) << "scene " << s;
  o.max_pairs = 1000;
  cuda::AxisSweep limited(o);
  EXPECT_THROW(limited.update(lanes_of(cuda_test::all_on_one_point(100))), CapacityExceeded);
}

TEST(CudaDevice, LbvhPeerMatchesTheOracle) {
  REQUIRE_DEVICE();
  std::vector<std::vector<BoxArray>> runs;
  for (ScenarioKind kind : kKinds) runs.push_back(cuda_test::scenario_frames(kind, 4000, 3));
  runs.push_back({cuda_test::all_on_one_point(2000), cuda_test::all_on_one_point(2000)});
  runs.push_back({cuda_test::spanning_world(300, 2000), cuda_test::spanning_world(300, 2000)});
  runs.push_back({cuda_test::extreme_boxes(2000), cuda_test::extreme_boxes(2000)});
  BoxArray one(1), two(2);
  one.set(0, Aabb{{0, 0, 0}, {1, 1, 1}});
  two.set(0, Aabb{{1, 1, 1}, {2, 2, 2}});
  two.set(1, Aabb{{0, 0, 0}, {1, 1, 1}});
  runs.push_back({BoxArray{}, one, two});
  for (bool sorted : {true, false}) {
    cuda::FrameOptions o;
    o.sorted = sorted;
    o.threads = std::max(2u, std::thread::hardware_concurrency());
    for (std::size_t r = 0; r < runs.size(); ++r) {
      o.launcher = cuda::Launcher::Host;
      cuda::Lbvh host(o);
      o.launcher = cuda::Launcher::Device;
      cuda::Lbvh device(o);
      for (std::size_t f = 0; f < runs[r].size(); ++f) {
        const BoxArray& boxes = runs[r][f];
        const std::vector<Pair> expected = host.update(lanes_of(boxes));
        ASSERT_EQ(device.update(lanes_of(boxes)), expected) << "run " << r << " frame " << f << " sorted " << sorted;
        EXPECT_EQ(device.info().pairs, expected.size());
        if (sorted) {
          ASSERT_EQ(expected, cuda_test::all_pairs(boxes)) << "run " << r << " frame " << f;
        }
        if (f > 0 && boxes.size() == runs[r][f - 1].size()) {
          EXPECT_EQ(device.info().allocations, 0u) << "run " << r << " frame " << f << ": a steady frame allocated";
        }
      }
    }
  }
  cuda::FrameOptions o;
  o.launcher = cuda::Launcher::Device;
  o.max_pairs = 1000;
  cuda::Lbvh limited(o);
  EXPECT_THROW(limited.update(lanes_of(cuda_test::all_on_one_point(100))), CapacityExceeded);  // 4,950 pairs
  EXPECT_EQ(limited.update(lanes_of(cuda_test::all_on_one_point(45))).size(), 990u);
}

#ifdef HBP_TEST_CUDA_ENGINES
TEST(CudaDevice, CellEngineInTheHybridSystem) {
  REQUIRE_DEVICE();
  cuda::register_cell_engines();
  for (ScenarioKind kind : kKinds) {
    const auto frames = cuda_test::scenario_frames(kind, 3000, 2);
    BroadPhaseOptions o;
    o.engine = "cuda";
    o.threads = 2;
    HybridBroadPhase hybrid(o);
    for (std::size_t f = 0; f < frames.size(); ++f)
      ASSERT_EQ(hybrid.update(frames[f]), cuda_test::all_pairs(frames[f])) << scenario_kind_name(kind);
  }
}
#endif

}  // namespace
}  // namespace hbp
