// SPDX-License-Identifier: MIT
// The distributed broad phase against the single-process oracle, frame by
// frame, on whatever rank count mpirun gives (CTest runs 1, 2, 3, 4 and 7).
// Every rank builds the same world; each supplies the boxes of the objects it
// owned last frame (new objects: id % ranks), as a simulation would.
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include "hbp/brute_force.hpp"
#include "hbp/distributed_broadphase.hpp"
#include "hbp/error.hpp"
#include "hbp/scenario.hpp"

namespace {

using hbp::Aabb;
using hbp::BoxArray;
using hbp::Pair;

int world_rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}
int world_size() {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}
std::uint64_t sum_all(std::uint64_t v) {
  std::uint64_t s = 0;
  MPI_Allreduce(&v, &s, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  return s;
}

// One frame of the whole world: ascending ids and their boxes.
struct World {
  std::vector<std::uint32_t> ids;
  BoxArray boxes;
};
using WorldMaker = std::function<void(std::uint32_t frame, World& world)>;

struct RunTotals {
  std::uint64_t migrated = 0, ghosts = 0, rebalances = 0;
  std::vector<hbp::RankFrameStats> per_frame;  // this rank's stats, per frame
};

hbp::DistributedOptions test_options() {
  hbp::DistributedOptions o;
  o.local.threads = 1;  // several ranks share two cores
  return o;
}

// Runs `frames` frames; on every frame checks the union of the ranks' pairs
// against the oracle (no pair missing, none extra, none twice) and that each
// rank's pairs have their ownership point in its domain.
RunTotals check_against_oracle(const WorldMaker& make, std::uint32_t frames,
                               const hbp::DistributedOptions& options = test_options()) {
  const int rank = world_rank(), size = world_size();
  hbp::DistributedBroadPhase bp(MPI_COMM_WORLD, options);
  RunTotals totals;
  std::vector<char> present_before, mine_before;
  World world;
  for (std::uint32_t f = 0; f < frames; ++f) {
    make(f, world);
    const std::uint32_t max_id = world.ids.empty() ? 0 : world.ids.back() + 1;
    present_before.resize(max_id, 0);
    mine_before.resize(max_id, 0);
    std::vector<std::uint32_t> ids;
    BoxArray boxes;
    for (std::size_t i = 0; i < world.ids.size(); ++i) {
      const std::uint32_t id = world.ids[i];
      const bool mine = present_before[id] ? mine_before[id] != 0 : static_cast<int>(id % size) == rank;
      if (!mine) continue;
      ids.push_back(id);
      boxes.push_back(world.boxes.get(i));
    }
    const std::vector<Pair>& local = bp.update(ids, boxes);
    const hbp::RankFrameStats& s = bp.stats();
    totals.per_frame.push_back(s);
    totals.migrated += sum_all(s.migrated_out);
    totals.ghosts += sum_all(s.ghosts);
    totals.rebalances += s.rebalanced;

    // Ownership: each reported pair's point max(min_a, min_b) is in our domain.
    std::vector<std::uint32_t> index(max_id, UINT32_MAX);
    for (std::size_t i = 0; i < world.ids.size(); ++i) index[world.ids[i]] = static_cast<std::uint32_t>(i);
    const hbp::CellRegion domain = bp.domain();
    std::size_t outside = 0;
    for (const Pair& p : local) {
      const Aabb a = world.boxes.get(index[p.a]), b = world.boxes.get(index[p.b]);
      if (!domain.contains(std::max(a.min[0], b.min[0]), std::max(a.min[1], b.min[1]), std::max(a.min[2], b.min[2])))
        ++outside;
    }
    EXPECT_EQ(outside, 0u) << "rank " << rank << " frame " << f;
    EXPECT_TRUE(std::is_sorted(local.begin(), local.end()));
    EXPECT_EQ(sum_all(s.owned), world.ids.size()) << "frame " << f;
    EXPECT_EQ(s.owned, bp.owned_ids().size());

    const std::vector<Pair> all = hbp::gather_pairs(MPI_COMM_WORLD, local, 0);
    if (rank == 0) {
      std::vector<Pair> oracle = hbp::brute_force_pairs(world.boxes);
      for (Pair& p : oracle) p = {world.ids[p.a], world.ids[p.b]};  // ascending ids: still sorted
      EXPECT_EQ(all.size(), oracle.size()) << "frame " << f << " (a pair reported twice shows here)";
      EXPECT_TRUE(all == oracle) << "frame " << f << ": " << hbp::diff_pairs(oracle, all).summary();
    }
    // Next frame: the objects we own now are ours to supply.
    std::fill(present_before.begin(), present_before.end(), 0);
    std::fill(mine_before.begin(), mine_before.end(), 0);
    for (std::uint32_t id : world.ids) present_before[id] = 1;
    for (std::uint32_t id : bp.owned_ids()) mine_before[id] = 1;
  }
  return totals;
}

WorldMaker scenario_world(hbp::ScenarioKind kind, std::uint32_t n, std::uint64_t seed = 3) {
  hbp::ScenarioParams p;
  p.kind = kind;
  p.n = n;
  p.seed = seed;
  auto scenario = std::make_shared<hbp::Scenario>(p);
  return [scenario](std::uint32_t frame, World& w) {
    if (frame > 0) scenario->step();
    scenario->compute_boxes(w.boxes);
    w.ids.resize(w.boxes.size());
    for (std::uint32_t i = 0; i < w.ids.size(); ++i) w.ids[i] = i;
  };
}

TEST(DistributedBroadPhase, PaperScene) {
  const RunTotals t = check_against_oracle(scenario_world(hbp::ScenarioKind::Paper, 2000), 4);
  if (world_size() > 1) {
    EXPECT_GT(t.ghosts, 0u);
  }
}
TEST(DistributedBroadPhase, ClusteredScene) {
  check_against_oracle(scenario_world(hbp::ScenarioKind::Clustered, 2000), 3);
}
TEST(DistributedBroadPhase, FlatScene) { check_against_oracle(scenario_world(hbp::ScenarioKind::Flat, 2000), 3); }
TEST(DistributedBroadPhase, HugeObjectScene) {
  check_against_oracle(scenario_world(hbp::ScenarioKind::Huge, 1500), 3);
}
TEST(DistributedBroadPhase, DegenerateScene) {
  check_against_oracle(scenario_world(hbp::ScenarioKind::Degenerate, 1500), 3);
}

// Every object teleports every frame (new uniform position), so most change
// domain each frame; some vanish and others appear.
TEST(DistributedBroadPhase, ObjectsMigrateEveryFrameAppearAndVanish) {
  auto make = [](std::uint32_t frame, World& w) {
    std::mt19937 rng(1000 + frame);
    std::uniform_real_distribution<float> pos(0.0f, 100.0f), ext(0.5f, 6.0f);
    w.ids.clear();
    w.boxes.clear();
    for (std::uint32_t id = 0; id < 1600; ++id) {
      const float x = pos(rng), y = pos(rng), z = pos(rng), e = ext(rng);
      if ((id + frame) % 9 == 0) continue;  // absent this frame
      w.ids.push_back(id);
      w.boxes.push_back(Aabb{{x, y, z}, {x + e, y + e, z + e}});
    }
  };
  const RunTotals t = check_against_oracle(make, 5);
  if (world_size() > 1) {
    EXPECT_GT(t.migrated, 1600u);  // several frames of mass migration
  }
}

// One box covering the whole world: it ghosts into every domain and overlaps
// every object; exactly one rank reports each of its pairs.
TEST(DistributedBroadPhase, OneBoxCoversTheWorld) {
  hbp::ScenarioParams p;
  p.n = 1500;
  auto scenario = std::make_shared<hbp::Scenario>(p);
  auto make = [scenario](std::uint32_t frame, World& w) {
    if (frame > 0) scenario->step();
    scenario->compute_boxes(w.boxes);
    const Aabb b = scenario->world_bounds();
    w.boxes.push_back(Aabb{{b.min[0] - 100, b.min[1] - 100, b.min[2] - 100}, {b.max[0] + 100, b.max[1] + 100, b.max[2] + 100}});
    w.ids.resize(w.boxes.size());
    for (std::uint32_t i = 0; i < w.ids.size(); ++i) w.ids[i] = i;
  };
  check_against_oracle(make, 3);
}

// Boxes with faces exactly on the domain planes, and points (zero-size boxes)
// on them: the half-open rule at its edges.
TEST(DistributedBroadPhase, BoxesOnDomainPlanes) {
  auto make = [](std::uint32_t, World& w) {
    w.ids.clear();
    w.boxes.clear();
    std::uint32_t id = 0;
    for (int x = 0; x < 12; ++x)
      for (int y = 0; y < 12; ++y)
        for (int z = 0; z < 12; ++z) {
          const float fx = static_cast<float>(x), fy = static_cast<float>(y), fz = static_cast<float>(z);
          w.ids.push_back(id++);
          w.boxes.push_back(Aabb{{fx, fy, fz}, {fx + 1, fy + 1, fz + 1}});  // touching faces
          w.ids.push_back(id++);
          w.boxes.push_back(Aabb{{fx, fy, fz}, {fx, fy, fz}});  // a point on a corner
        }
  };
  check_against_oracle(make, 2);
}

TEST(DistributedBroadPhase, BalancedAndDeterministic) {
  const RunTotals a = check_against_oracle(scenario_world(hbp::ScenarioKind::Paper, 4000, 7), 3);
  const RunTotals b = check_against_oracle(scenario_world(hbp::ScenarioKind::Paper, 4000, 7), 3);
  ASSERT_EQ(a.per_frame.size(), b.per_frame.size());
  for (std::size_t f = 0; f < a.per_frame.size(); ++f) {
    EXPECT_EQ(a.per_frame[f].owned, b.per_frame[f].owned);
    EXPECT_EQ(a.per_frame[f].ghosts, b.per_frame[f].ghosts);
    EXPECT_EQ(a.per_frame[f].bytes_sent, b.per_frame[f].bytes_sent);
    EXPECT_EQ(a.per_frame[f].pairs, b.per_frame[f].pairs);
    // Owned within the rebalance threshold (5 %) of the mean.
    const double mean = 4000.0 / world_size();
    EXPECT_LE(std::abs(static_cast<double>(a.per_frame[f].owned) - mean), 0.05 * mean) << "frame " << f;
  }
  EXPECT_EQ(a.per_frame[0].rebalanced, 1u);
}

// A static world: after the first frame no ghost box changes, so the refresh
// sends headers only.
TEST(DistributedBroadPhase, StaticWorldSendsNoGhostBoxes) {
  hbp::ScenarioParams p;
  p.n = 1500;
  const hbp::Scenario scenario(p);
  auto make = [&scenario](std::uint32_t, World& w) {
    scenario.compute_boxes(w.boxes);
    w.ids.resize(w.boxes.size());
    for (std::uint32_t i = 0; i < w.ids.size(); ++i) w.ids[i] = i;
  };
  const RunTotals t = check_against_oracle(make, 3);
  for (std::size_t f = 1; f < t.per_frame.size(); ++f) {
    EXPECT_EQ(t.per_frame[f].ghosts_sent, 0u);
    EXPECT_EQ(t.per_frame[f].migrated_out, 0u);
  }
  if (world_size() > 1) {
    EXPECT_GT(sum_all(t.per_frame[0].ghosts_sent), 0u);
  }
}

// Bad input on one rank: every rank throws (no rank hangs in a collective),
// the message names the object, and the next frame works.
TEST(DistributedBroadPhase, InvalidBoxOnOneRankThrowsEverywhere) {
  const int rank = world_rank(), size = world_size();
  hbp::DistributedBroadPhase bp(MPI_COMM_WORLD, test_options());
  std::vector<std::uint32_t> ids = {static_cast<std::uint32_t>(rank)};
  BoxArray boxes;
  boxes.push_back(Aabb{{0, 0, 0}, {1, 1, 1}});
  if (rank == size - 1) boxes.set(0, Aabb{{0, NAN, 0}, {1, 1, 1}});
  try {
    bp.update(ids, boxes);
    ADD_FAILURE() << "no exception";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("object id " + std::to_string(size - 1)), std::string::npos) << e.what();
  }
  boxes.set(0, Aabb{{0, 0, 0}, {1, 1, 1}});
  const std::vector<Pair> all = hbp::gather_pairs(MPI_COMM_WORLD, bp.update(ids, boxes), 0);
  if (rank == 0) {
    EXPECT_EQ(all.size(), static_cast<std::size_t>(size) * (size - 1) / 2);
  }

  // The same id supplied by two ranks.
  if (size > 1) {
    ids[0] = 0;
    EXPECT_THROW(bp.update(ids, boxes), hbp::InvalidInput);
  }
}

// A pair limit tripped on some ranks only: every rank throws CapacityExceeded.
TEST(DistributedBroadPhase, PairLimitThrowsOnEveryRank) {
  hbp::DistributedOptions o = test_options();
  o.local.max_pairs = 5;
  hbp::DistributedBroadPhase bp(MPI_COMM_WORLD, o);
  std::vector<std::uint32_t> ids;
  BoxArray boxes;
  if (world_rank() == 0) {  // 40 nested boxes around the origin: 780 pairs, on whichever rank owns them
    for (std::uint32_t i = 0; i < 40; ++i) {
      const float e = 1.0f + static_cast<float>(i);
      ids.push_back(i);
      boxes.push_back(Aabb{{-e, -e, -e}, {e, e, e}});
    }
  }
  EXPECT_THROW(bp.update(ids, boxes), hbp::CapacityExceeded);
  EXPECT_TRUE(bp.pairs().empty());
}

}  // namespace

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  ::testing::InitGoogleTest(&argc, argv);
  const int failed = RUN_ALL_TESTS();
  int any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return any;
}
