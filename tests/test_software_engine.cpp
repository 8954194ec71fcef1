// SPDX-License-Identifier: MIT
// The software engine's kernels on every instruction set this CPU has, the
// per-cell ordering, and the k-d partition's membership rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "engines/box_kernels.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/kd_partition.hpp"
#include "hbp/scenario.hpp"
#include "hbp/software_engine.hpp"
#include "engines/min_x_order.hpp"

namespace {

using hbp::BoxArray;
using hbp::CellRegion;
using hbp::Pair;
namespace k = hbp::kernels;

std::vector<k::Isa> available_isas() {
  std::vector<k::Isa> isas{k::Isa::Scalar};
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi2")) isas.push_back(k::Isa::Avx2);
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
      __builtin_cpu_supports("avx512vl"))
    isas.push_back(k::Isa::Avx512);
  return isas;
}

BoxArray random_boxes(std::uint32_t n, float world, float size, std::mt19937& rng, bool sorted) {
  std::uniform_real_distribution<float> pos(-world, world), ext(0.0f, size);
  std::vector<hbp::Aabb> v(n);
  for (auto& b : v) {
    for (int a = 0; a < 3; ++a) {
      b.min[a] = pos(rng);
      b.max[a] = b.min[a] + ext(rng);
    }
  }
  if (sorted) std::sort(v.begin(), v.end(), [](const auto& x, const auto& y) { return x.min[0] < y.min[0]; });
  BoxArray boxes;
  for (const auto& b : v) boxes.push_back(b);
  return boxes;
}

// Pairs of the oracle whose ownership point lies in the region.
std::vector<Pair> owned_oracle(const BoxArray& boxes, const CellRegion& r) {
  std::vector<Pair> out;
  for (const Pair& p : hbp::brute_force_pairs(boxes)) {
    const auto a = boxes.get(p.a), b = boxes.get(p.b);
    if (r.contains(std::max(a.min[0], b.min[0]), std::max(a.min[1], b.min[1]), std::max(a.min[2], b.min[2])))
      out.push_back(p);
  }
  return out;
}

// Ids reported for the boxes: scrambled and spread over the 32 bits (the
// kernels must map and order them), padded like the box lanes.
std::vector<std::uint32_t> scrambled_ids(std::uint32_t n) {
  std::vector<std::uint32_t> ids(n + 16, 0xFFFFFFFFu);
  for (std::uint32_t i = 0; i < n; ++i) ids[i] = (n - 1 - i) * 2654435761u % 4294967291u;
  return ids;
}

// The oracle's pairs with each index replaced by its id, canonical and sorted.
std::vector<Pair> with_ids(const std::vector<Pair>& pairs, const std::vector<std::uint32_t>& ids) {
  std::vector<Pair> out;
  for (const Pair& p : pairs) out.push_back(hbp::make_pair(ids[p.a], ids[p.b]));
  hbp::canonicalize(out);
  return out;
}

// Runs a kernel to the end through an output of `capacity` pairs, draining
// it whenever the kernel stops; checks the pairs are canonical and the count
// kernel agrees.
// The pairs in the order the kernel found them.
std::vector<Pair> run_kernel_in_order(k::Kernel kernel, k::CountKernel counter, const BoxArray& boxes,
                                      const std::vector<std::uint32_t>& ids, const CellRegion& r,
                                      std::size_t capacity) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  std::vector<std::uint32_t> codes(n + 16);
  const float* const min[3] = {boxes.min(0), boxes.min(1), boxes.min(2)};
  k::write_owner_codes(min, n, r, codes.data());
  k::KernelInput in{{boxes.min(0), boxes.min(1), boxes.min(2)}, {boxes.max(0), boxes.max(1), boxes.max(2)},
                    ids.data(), codes.data(), n, r};
  std::vector<std::uint32_t> first(capacity), second(capacity);
  std::vector<Pair> pairs;
  std::uint32_t row = 0;
  while (true) {
    k::KernelOutput out{first.data(), second.data(), capacity, 0};
    const std::uint32_t from = row;
    row = kernel(in, row, out);
    EXPECT_EQ(counter(in, from) - counter(in, row), out.count) << "count kernel disagrees on rows " << from << "-" << row;
    // Every ISA's canonical_pairs must agree with the scalar one; an exact-size
    // destination catches a vector tail written past the end (ASan).
    std::vector<Pair> canonical(out.count), reference(out.count);
    k::canonical_pairs(k::selected_isa())(first.data(), second.data(), out.count,
                                          reinterpret_cast<std::uint32_t*>(canonical.data()));
    k::canonical_pairs_scalar(first.data(), second.data(), out.count, reinterpret_cast<std::uint32_t*>(reference.data()));
    EXPECT_EQ(canonical, reference);
    pairs.insert(pairs.end(), canonical.begin(), canonical.end());
    if (row >= n) break;
    if (row == from) {
      ADD_FAILURE() << "kernel makes no progress at row " << row << " with room " << capacity;
      break;
    }
  }
  for (const Pair& p : pairs) EXPECT_LT(p.a, p.b) << "not canonical";
  return pairs;
}

std::vector<Pair> run_kernel(k::Kernel kernel, k::CountKernel counter, const BoxArray& boxes,
                             const std::vector<std::uint32_t>& ids, const CellRegion& r, std::size_t capacity) {
  std::vector<Pair> pairs = run_kernel_in_order(kernel, counter, boxes, ids, r, capacity);
  hbp::canonicalize(pairs);
  return pairs;
}

std::vector<Pair> run_kernel(k::Kernel kernel, k::CountKernel counter, const BoxArray& boxes, const CellRegion& r,
                             std::size_t capacity) {
  std::vector<std::uint32_t> ids(boxes.size() + 16);
  for (std::uint32_t i = 0; i < ids.size(); ++i) ids[i] = i;
  return run_kernel(kernel, counter, boxes, ids, r, capacity);
}

TEST(SoftwareKernels, EveryIsaMatchesTheOracleWithAndWithoutARegion) {
  std::mt19937 rng(5);
  for (k::Isa isa : available_isas()) {
    for (std::uint32_t n : {0u, 1u, 2u, 15u, 16u, 17u, 33u, 200u, 700u}) {
      const BoxArray boxes = random_boxes(n, 50, 20, rng, true);
      const CellRegion regions[] = {CellRegion::everything(), {{-10, -20, -5}, {10, 30, 25}}};
      for (const CellRegion& r : regions) {
        const auto want = owned_oracle(boxes, r);
        EXPECT_EQ(run_kernel(k::sweep_kernel(isa), k::sweep_count_kernel(isa), boxes, r, 4 * n + 64), want)
            << k::isa_name(isa) << " sweep n=" << n;
        EXPECT_EQ(run_kernel(k::allpairs_kernel(isa), k::allpairs_count_kernel(isa), boxes, r, 4 * n + 64), want)
            << k::isa_name(isa) << " all-pairs n=" << n;
        const auto ids = scrambled_ids(n);
        EXPECT_EQ(run_kernel(k::sweep_kernel(isa), k::sweep_count_kernel(isa), boxes, ids, r, 4 * n + 64),
                  with_ids(want, ids))
            << k::isa_name(isa) << " sweep with ids n=" << n;
        EXPECT_EQ(run_kernel(k::allpairs_kernel(isa), k::allpairs_count_kernel(isa), boxes, ids, r, 4 * n + 64),
                  with_ids(want, ids))
            << k::isa_name(isa) << " all-pairs with ids n=" << n;
      }
    }
  }
}

// Cells of members (min < hi on every axis, as the partition makes them) and
// cells with stray boxes: every kernel's ownership (the AVX-512 owner codes,
// the AVX2 and scalar rule) must give the owned oracle's pairs.
// Coordinates on a lattice that includes the planes (boxes starting exactly
// on lo, row and candidate minima on both sides of lo, zero-size boxes); the
// cells' pairs must be the owned oracle's, and together every pair once.
TEST(SoftwareKernels, MemberCellsAndStrayBoxesOwnExactlyByTheRule) {
  const float inf = std::numeric_limits<float>::infinity();
  const float cuts[] = {-inf, 4, 8, inf};
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> at(-1, 12), size(0, 4);
  BoxArray boxes;
  for (int i = 0; i < 400; ++i) {
    hbp::Aabb b;
    for (int a = 0; a < 3; ++a) {
      b.min[a] = static_cast<float>(at(rng));
      b.max[a] = b.min[a] + static_cast<float>(size(rng));
    }
    boxes.push_back(b);
  }
  const std::vector<Pair> all = hbp::brute_force_pairs(boxes);
  ASSERT_GT(all.size(), 1000u);
  for (k::Isa isa : available_isas()) {
    std::vector<Pair> found;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int l = 0; l < 3; ++l) {
          const CellRegion r{{cuts[i], cuts[j], cuts[l]}, {cuts[i + 1], cuts[j + 1], cuts[l + 1]}};
          std::vector<std::uint32_t> members;
          for (std::uint32_t o = 0; o < boxes.size(); ++o) {
            const hbp::Aabb b = boxes.get(o);
            bool in = true;
            for (int a = 0; a < 3; ++a) in &= b.min[a] < r.hi[a] && b.max[a] >= r.lo[a];
            if (in) members.push_back(o);
          }
          // Members alone, then with one stray box that starts on hi (not a
          // member: the full rule must keep it from owning anything).
          for (bool stray : {false, true}) {
            std::vector<std::uint32_t> cell = members;
            if (stray && r.hi[1] < inf) {
              for (std::uint32_t o = 0; o < boxes.size(); ++o)
                if (boxes.get(o).min[1] == r.hi[1]) {
                  cell.push_back(o);
                  break;
                }
            }
            std::sort(cell.begin(), cell.end(), [&](std::uint32_t a, std::uint32_t b) {
              const float x = boxes.min(0)[a], y = boxes.min(0)[b];
              return x < y || (x == y && a < b);
            });
            BoxArray local;
            std::vector<std::uint32_t> ids(cell.size() + 16, 0xFFFFFFFFu);
            for (std::size_t q = 0; q < cell.size(); ++q) {
              local.push_back(boxes.get(cell[q]));
              ids[q] = cell[q];
            }
            const auto n = static_cast<std::uint32_t>(cell.size());
            const std::vector<Pair> want = with_ids(owned_oracle(local, r), ids);
            const std::vector<Pair> got = run_kernel(k::sweep_kernel(isa), k::sweep_count_kernel(isa), local, ids, r,
                                                     2 * n + 64);
            ASSERT_EQ(got, want) << k::isa_name(isa) << " cell " << i << j << l << (stray ? " with a stray box" : "");
            if (!stray) found.insert(found.end(), got.begin(), got.end());
          }
        }
    EXPECT_EQ(hbp::canonicalize(found), 0u) << k::isa_name(isa) << ": a pair owned by two cells";
    EXPECT_EQ(found, all) << k::isa_name(isa) << ": every pair once over the cells";
  }
}

TEST(SoftwareKernels, DenseCellsResumeWhenTheOutputIsFull) {
  std::mt19937 rng(9);
  for (k::Isa isa : available_isas()) {
    const BoxArray boxes = random_boxes(300, 5, 20, rng, true);  // nearly every pair overlaps
    const auto want = owned_oracle(boxes, CellRegion::everything());
    ASSERT_GT(want.size(), 20000u);
    // The least room that makes progress (two rows at a time), and a little more.
    for (std::size_t room : {k::min_output(300), k::min_output(300) + 37}) {
      EXPECT_EQ(run_kernel(k::sweep_kernel(isa), k::sweep_count_kernel(isa), boxes, CellRegion::everything(), room),
                want)
          << k::isa_name(isa);
      EXPECT_EQ(
          run_kernel(k::allpairs_kernel(isa), k::allpairs_count_kernel(isa), boxes, CellRegion::everything(), room),
          want)
          << k::isa_name(isa);
    }
  }
}

// The AVX-512 sweep starts the candidates of two rows that both begin below
// the region's lo x at the first box that does not (two such boxes own no
// pair). Prefixes of every length that matters (none, one row, a pair of
// rows, odd, all but one, all), dense and sparse cells, resumed with the
// least room: always the owned oracle's pairs, and the same order whatever
// the room.
TEST(SoftwareKernels, RowsBelowTheLowXPlaneSkipTheirPrefix) {
  std::mt19937 rng(17);
  for (k::Isa isa : available_isas()) {
    for (const float size : {1.5f, 12.0f}) {
      const std::uint32_t n = 37;
      const BoxArray boxes = random_boxes(n, 6, size, rng, true);
      const auto ids = scrambled_ids(n);
      std::vector<float> los;
      for (std::uint32_t below : {0u, 1u, 2u, 3u, 17u, 18u, 35u, 36u}) los.push_back(boxes.min(0)[below]);
      los.push_back(std::nextafter(boxes.min(0)[n - 1], 100.0f));  // every box below lo x
      for (const float lo : los) {
        const CellRegion r{{lo, -4, -3}, {lo + 5, 3, 8}};
        const auto want = with_ids(owned_oracle(boxes, r), ids);
        const auto roomy = run_kernel_in_order(k::sweep_kernel(isa), k::sweep_count_kernel(isa), boxes, ids, r, 1 << 12);
        auto sorted = roomy;
        hbp::canonicalize(sorted);
        EXPECT_EQ(sorted, want) << k::isa_name(isa) << " lo x " << lo << " size " << size;
        EXPECT_EQ(run_kernel_in_order(k::sweep_kernel(isa), k::sweep_count_kernel(isa), boxes, ids, r, k::min_output(n)),
                  roomy)
            << k::isa_name(isa) << " lo x " << lo << " size " << size;
      }
    }
  }
}

// The hybrid system drains a cell's hits through outputs of different room
// (a worker's stage, a counted cell's first rows): the order of the hits must
// not depend on it, or the frame's pair order would depend on the thread
// count. (The AVX-512 sweep once fell back to single rows when the room was
// short, which reordered the hits of the rows after.)
TEST(SoftwareKernels, HitOrderDoesNotDependOnTheRoom) {
  std::mt19937 rng(13);
  const BoxArray boxes = random_boxes(301, 6, 20, rng, true);
  const auto ids = scrambled_ids(301);
  const CellRegion r{{-10, -20, -5}, {10, 30, 25}};
  for (k::Isa isa : available_isas()) {
    for (const bool sweep : {true, false}) {
      const k::Kernel kernel = sweep ? k::sweep_kernel(isa) : k::allpairs_kernel(isa);
      const k::CountKernel counter = sweep ? k::sweep_count_kernel(isa) : k::allpairs_count_kernel(isa);
      const std::vector<Pair> roomy = run_kernel_in_order(kernel, counter, boxes, ids, r, 1 << 20);
      ASSERT_GT(roomy.size(), 5000u);
      for (std::size_t room : {k::min_output(301), k::min_output(301) + 1, k::min_output(301) + 300, std::size_t{5000}})
        EXPECT_EQ(run_kernel_in_order(kernel, counter, boxes, ids, r, room), roomy)
            << k::isa_name(isa) << (sweep ? " sweep" : " all-pairs") << ", room " << room;
    }
  }
}

// The AVX-512 sweep stores a pair of rows' hits after scanning them
// (deferred) in cells of up to 16,512 boxes and during the scan in larger
// ones: the same hits in the same order either way. A cell of 16,000 boxes
// (deferred) and the same cell with 1,000 more far beyond it in x (17,000,
// stored at once) must begin with the same list; the far boxes' own pairs
// come after it.
TEST(SoftwareKernels, LargeCellsStoreInTheSameOrderAsDeferredOnes) {
  std::mt19937 rng(21);
  const BoxArray near = random_boxes(16000, 100, 12, rng, true);
  BoxArray all = near;
  const BoxArray far = random_boxes(1000, 20, 6, rng, true);
  for (std::uint32_t i = 0; i < far.size(); ++i) {
    hbp::Aabb b = far.get(i);
    b.min[0] += 1000;
    b.max[0] += 1000;
    all.push_back(b);
  }
  const std::vector<std::uint32_t> all_ids = scrambled_ids(17000);
  std::vector<std::uint32_t> near_ids(all_ids.begin(), all_ids.begin() + 16000);
  near_ids.resize(16000 + 16, 0xFFFFFFFFu);
  const CellRegion r{{-80, -90, -100}, {2000, 90, 100}};
  for (k::Isa isa : available_isas()) {
    const std::vector<Pair> near_pairs =
        run_kernel_in_order(k::sweep_kernel(isa), k::sweep_count_kernel(isa), near, near_ids, r, 1 << 20);
    const std::vector<Pair> all_pairs =
        run_kernel_in_order(k::sweep_kernel(isa), k::sweep_count_kernel(isa), all, all_ids, r, 1 << 20);
    ASSERT_GT(near_pairs.size(), 10000u) << k::isa_name(isa);
    ASSERT_GT(all_pairs.size(), near_pairs.size() + 100) << k::isa_name(isa);
    EXPECT_TRUE(std::equal(near_pairs.begin(), near_pairs.end(), all_pairs.begin())) << k::isa_name(isa);
    std::vector<Pair> sorted = all_pairs;
    hbp::canonicalize(sorted);
    EXPECT_EQ(sorted, run_kernel(k::sweep_kernel(k::Isa::Scalar), k::sweep_count_kernel(k::Isa::Scalar), all,
                                 all_ids, r, 1 << 20))
        << k::isa_name(isa);
  }
}

TEST(SoftwareEngine, UnsortedInputThroughTheCellEngineInterface) {
  std::mt19937 rng(2);
  const BoxArray boxes = random_boxes(500, 40, 15, rng, false);
  for (auto kernel : {hbp::SoftwareEngine::Kernel::Sweep, hbp::SoftwareEngine::Kernel::AllPairs}) {
    hbp::SoftwareEngine engine(kernel);
    std::vector<Pair> got;
    engine.find_pairs(boxes, got);
    hbp::canonicalize(got);
    EXPECT_EQ(got, hbp::brute_force_pairs(boxes)) << engine.name();
  }
}

TEST(SoftwareEngine, PairLimitStopsADenseCell) {
  BoxArray boxes;
  for (int i = 0; i < 2000; ++i) boxes.push_back({{0, 0, 0}, {1, 1, 1}});
  hbp::SoftwareEngine engine;
  engine.set_pair_limit(100000);
  std::vector<Pair> out;
  EXPECT_THROW(engine.find_owned_pairs(boxes, CellRegion::everything(), out), hbp::CapacityExceeded);
  EXPECT_LT(out.size(), 200000u);
}

TEST(MinXOrder, SortsLikeAStableSortOnValue) {
  std::mt19937 rng(1);
  std::vector<std::uint32_t> order;
  std::vector<std::uint64_t> scratch;
  for (std::uint32_t n : {0u, 1u, 5u, 48u, 49u, 1000u, 5000u}) {
    for (int spread : {0, 1, 2}) {
      std::vector<float> x(n);
      std::uniform_real_distribution<float> wide(-1e6f, 1e6f), narrow(100.0f, 100.5f);
      for (std::uint32_t i = 0; i < n; ++i) {
        x[i] = spread == 0 ? wide(rng) : (spread == 1 ? narrow(rng) : static_cast<float>(rng() % 7) - 3.0f);
        if (i % 17 == 0) x[i] = (i % 2) ? -0.0f : 0.0f;
      }
      hbp::min_x_order(x.data(), n, order, scratch);
      ASSERT_EQ(order.size(), n);
      std::vector<std::uint32_t> want(n);
      for (std::uint32_t i = 0; i < n; ++i) want[i] = i;
      std::stable_sort(want.begin(), want.end(), [&](auto a, auto b) { return x[a] < x[b]; });
      for (std::uint32_t i = 0; i < n; ++i) ASSERT_EQ(x[order[i]], x[want[i]]) << "n=" << n << " i=" << i;
      std::vector<std::uint32_t> sorted = order;
      std::sort(sorted.begin(), sorted.end());
      for (std::uint32_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i);  // a permutation
      // in_min_x_order: true once ordered (-0 and +0 equal), false with any
      // one pair swapped, wherever it sits in the vector lanes.
      std::vector<float> ordered(n);
      for (std::uint32_t i = 0; i < n; ++i) ordered[i] = x[order[i]];
      ASSERT_TRUE(hbp::in_min_x_order(ordered.data(), n)) << "n=" << n;
      for (std::uint32_t i = 1; i < n; i += 1 + i / 3) {
        if (!(ordered[i - 1] < ordered[i])) continue;
        std::swap(ordered[i - 1], ordered[i]);
        ASSERT_FALSE(hbp::in_min_x_order(ordered.data(), n)) << "n=" << n << " swapped at " << i;
        std::swap(ordered[i - 1], ordered[i]);
      }
      if (n > 1 && ordered[n - 2] < ordered[n - 1]) {
        std::swap(ordered[n - 2], ordered[n - 1]);
        ASSERT_FALSE(hbp::in_min_x_order(ordered.data(), n)) << "n=" << n << " last pair";
      }
    }
  }
}

// Every object is in exactly the cells whose half-open region its closed box
// reaches (min < hi and max >= lo on every axis), frame after frame while the
// tree is maintained incrementally.
TEST(KdPartition, MembershipFollowsTheRoutingRuleAcrossFrames) {
  hbp::ScenarioParams p;
  p.n = 3000;
  p.seed = 4;
  p.linear_speed = 400;  // fast movers: migrations, splits, merges
  hbp::Scenario scene(p);
  hbp::KdPartition partition(64, 1.0f);  // 0.5 happens to need no split here
  BoxArray boxes;
  std::uint32_t splits = 0;
  for (int f = 0; f < 12; ++f) {
    scene.compute_boxes(boxes);
    partition.update(boxes);
    splits += partition.stats().splits;
    std::vector<std::vector<std::uint32_t>> want(partition.cell_count());
    for (std::uint32_t c = 0; c < partition.cell_count(); ++c) {
      const CellRegion& r = partition.region(c);
      for (std::uint32_t i = 0; i < boxes.size(); ++i) {
        const auto b = boxes.get(i);
        bool in = true;
        for (int a = 0; a < 3; ++a) in &= b.min[a] < r.hi[a] && b.max[a] >= r.lo[a];
        if (in) want[c].push_back(i);
      }
      std::vector<std::uint32_t> got;
      const auto cell = partition.cell(c);
      for (std::size_t k = 0; k < cell.size(); ++k) {
        const auto& e = cell[k];
        got.push_back(e.id);
        const auto b = boxes.get(e.id);
        ASSERT_EQ(e.min[0], b.min[0]);
        ASSERT_EQ(e.max[2], b.max[2]);
        if (k > 0) {  // the contract: min x order, ties by id
          ASSERT_TRUE(cell[k - 1].min[0] < e.min[0] || (cell[k - 1].min[0] == e.min[0] && cell[k - 1].id < e.id))
              << "frame " << f << " cell " << c << " entry " << k;
        }
      }
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, want[c]) << "frame " << f << " cell " << c;
    }
    EXPECT_LE(partition.stats().max_cell, 64u) << "frame " << f;
    scene.step();
  }
  EXPECT_GT(splits, 0u);
}

TEST(ReadmeExample, CompilesAndFindsThePairs) {
  const std::uint32_t n = 3;
  const float x0[] = {0, 1, 5}, y0[] = {0, 0, 5}, z0[] = {0, 0, 5};
  const float x1[] = {1, 2, 6}, y1[] = {1, 1, 6}, z1[] = {1, 1, 6};
  std::vector<Pair> seen;
  auto on_overlap = [&](std::uint32_t a, std::uint32_t b) { seen.push_back({a, b}); };
  hbp::BoxArray boxes(n);
  for (std::uint32_t i = 0; i < n; ++i) boxes.set(i, {{x0[i], y0[i], z0[i]}, {x1[i], y1[i], z1[i]}});
  hbp::HybridBroadPhase broad_phase({.engine = "sw", .threads = 2});
  for (hbp::Pair p : broad_phase.update(boxes)) on_overlap(p.a, p.b);
  EXPECT_EQ(seen, (std::vector<Pair>{{0, 1}}));
}

// HBP_SIMD: the three lower-case names (capped at what the CPU has), unset or
// empty for the best; anything else is an error naming the accepted values.
TEST(SimdChoice, AcceptedValuesAndErrors) {
  EXPECT_EQ(k::isa_for_request(nullptr, k::Isa::Avx512), k::Isa::Avx512);
  EXPECT_EQ(k::isa_for_request("", k::Isa::Avx2), k::Isa::Avx2);
  EXPECT_EQ(k::isa_for_request("scalar", k::Isa::Avx512), k::Isa::Scalar);
  EXPECT_EQ(k::isa_for_request("avx2", k::Isa::Avx512), k::Isa::Avx2);
  EXPECT_EQ(k::isa_for_request("avx512", k::Isa::Avx512), k::Isa::Avx512);
  EXPECT_EQ(k::isa_for_request("avx512", k::Isa::Avx2), k::Isa::Avx2);  // documented fallback
  EXPECT_EQ(k::isa_for_request("avx2", k::Isa::Scalar), k::Isa::Scalar);
  for (const char* bad : {"bogus", "AVX2", "Scalar", "avx", "avx512 ", " scalar", "sse"}) {
    try {
      (void)k::isa_for_request(bad, k::Isa::Avx512);
      ADD_FAILURE() << "HBP_SIMD=" << bad << " accepted";
    } catch (const hbp::InvalidInput& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(std::string("HBP_SIMD=") + bad), std::string::npos) << msg;
      EXPECT_NE(msg.find("scalar, avx2 or avx512"), std::string::npos) << msg;
    }
  }
}

}  // namespace
