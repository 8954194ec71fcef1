// SPDX-License-Identifier: MIT
#pragma once
// The hybrid broad phase distributed over MPI ranks (docs/distributed.md).
//
// Space is split into one half-open domain per rank by the top levels of a
// k-d tree (recursive bisection of the object centres by count). A rank owns
// the objects whose box centre lies in its domain and holds ghost copies of
// foreign objects whose closed boxes reach its closed domain. It runs the
// single-process hbp::HybridBroadPhase on owned + ghost objects and keeps the
// pairs whose ownership point max(min_a, min_b) lies in its half-open domain:
// every overlapping pair is reported by exactly one rank, with no gather.
//
//   hbp::DistributedBroadPhase bp(MPI_COMM_WORLD, {});
//   bp.update(ids, boxes);          // this rank's objects (any split at first)
//   for (hbp::Pair p : bp.pairs())  // this rank's share, global ids, sorted
//   ... next frame: supply the boxes of bp.owned_ids() (or any other split).
//
// Every member function except the accessors is collective over the
// communicator. Built only when MPI is found (CMake target hbp::distributed);
// the core library has no MPI dependency.
#include <mpi.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/pair.hpp"

namespace hbp {

struct DistributedOptions {
  // The per-rank hybrid broad phase (sorted is forced on). Its max_pairs
  // bounds each rank's local pairs; past it every rank throws CapacityExceeded.
  BroadPhaseOptions local;
  // The domains are rebuilt when max_r |owned_r - mean| / mean exceeds this
  // (plus the imbalance the last bisection itself could not remove, e.g.
  // identical centres that no plane separates).
  double rebalance_threshold = 0.05;
};

// One rank's counts for one frame (counted, deterministic for a given rank
// count and input) and its measured wall times.
struct RankFrameStats {
  std::uint64_t owned = 0;         // objects whose centre lies in this domain
  std::uint64_t ghosts = 0;        // foreign objects held as ghost copies
  std::uint64_t local_pairs = 0;   // pairs found among owned + ghosts
  std::uint64_t pairs = 0;         // pairs this rank reports (ownership point here)
  std::uint64_t migrated_out = 0;  // objects sent to their new owner
  std::uint64_t ghosts_sent = 0;   // ghost entries sent: added + changed boxes
  std::uint64_t ghosts_added = 0;  // of those, new at the receiver (id + box)
  std::uint64_t ghosts_removed = 0;
  std::uint64_t bytes_sent = 0;    // payload to other ranks: migration + ghosts
  std::uint32_t rebalanced = 0;    // 1 when the domains were rebuilt this frame
  std::uint32_t pad_ = 0;
  double decompose_ms = 0, migrate_ms = 0, ghost_ms = 0, local_ms = 0, filter_ms = 0, wall_ms = 0;
};
static_assert(sizeof(RankFrameStats) == 10 * 8 + 6 * 8, "RankFrameStats is sent as bytes");

class DistributedBroadPhase {
 public:
  DistributedBroadPhase(MPI_Comm comm, const DistributedOptions& options = {});
  ~DistributedBroadPhase();
  DistributedBroadPhase(DistributedBroadPhase&&) noexcept;
  DistributedBroadPhase& operator=(DistributedBroadPhase&&) noexcept;

  // One frame. `ids` are the global ids of the boxes this rank supplies; over
  // all ranks every object of the frame is supplied exactly once (objects not
  // supplied have left the world, new ids have appeared). Collective: bad
  // boxes or duplicate ids on any rank make every rank throw InvalidInput
  // (the rank holding the defect names the object). A bad box changes
  // nothing; a duplicate id (found after migration) makes every rank drop its
  // objects and ghosts, so the next update starts afresh from what is
  // supplied (the domains are kept).
  const std::vector<Pair>& update(const std::vector<std::uint32_t>& ids, const BoxArray& boxes);

  // This rank's pairs of the last frame: global ids, canonical, sorted.
  const std::vector<Pair>& pairs() const;
  // Global ids this rank owns after the last update, ascending.
  const std::vector<std::uint32_t>& owned_ids() const;
  // Boxes of owned_ids(), same order.
  const BoxArray& owned_boxes() const;
  const RankFrameStats& stats() const;
  // The local hybrid broad phase's figures of the last frame (owned + ghosts).
  const FrameStats& local_stats() const;
  // This rank's half-open domain (outermost domains extend to infinity).
  CellRegion domain() const;
  // The rank whose domain holds point (x, y, z) (half-open rule).
  int rank_of(float x, float y, float z) const;
  int rank() const;
  int size() const;

  // Collective: every rank's stats of the last frame, on `root` only (empty
  // elsewhere), in rank order.
  std::vector<RankFrameStats> gather_stats(int root = 0) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Collective: all ranks' pairs on `root`, sorted (empty elsewhere). For output
// only; the distributed broad phase itself never gathers.
std::vector<Pair> gather_pairs(MPI_Comm comm, const std::vector<Pair>& local, int root = 0);

}  // namespace hbp
