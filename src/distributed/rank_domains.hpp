// SPDX-License-Identifier: MIT
#pragma once
// The rank domains: the top levels of a k-d tree over the object centres,
// one leaf per rank, built by collective recursive bisection by count
// (docs/distributed.md). Regions are half-open [lo, hi); the outermost ones
// extend to infinity, so every point of space lies in exactly one domain.
#include <mpi.h>

#include <cstdint>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/cell_region.hpp"

namespace hbp::distributed {

class RankDomains {
 public:
  bool built() const { return !nodes_.empty(); }
  int ranks() const { return ranks_; }

  // Collective over comm (size P): splits the centres (this rank's share,
  // SoA) so that the domain of rank r receives about count * 1/P of them; a
  // node of k ranks gives floor(k/2) of them to its left child and the same
  // share of its objects (non-power-of-two P split proportionally). Axis:
  // the largest spread of the node's centres. Split: the smallest centre of
  // the right side (#{centre < split} = target when no centres tie), found
  // by bisection on the float's bits, one allreduce per step.
  void build(MPI_Comm comm, const float* cx, const float* cy, const float* cz, std::size_t n);

  // The rank whose half-open domain holds the point.
  int owner(float x, float y, float z) const;
  // Appends every rank whose closed domain intersects the closed box.
  void ranks_reaching(const Aabb& box, std::vector<int>& out) const;
  const CellRegion& region(int rank) const { return regions_[static_cast<std::size_t>(rank)]; }

 private:
  struct Node {
    int axis = -1;  // -1: leaf
    float split = 0;
    int child[2] = {-1, -1};
    int rank_lo = 0, rank_hi = 0;  // ranks [lo, hi) below this node
    CellRegion region = CellRegion::everything();
  };
  std::vector<Node> nodes_;
  std::vector<CellRegion> regions_;  // per rank
  int ranks_ = 0;
  mutable std::vector<int> stack_;
};

}  // namespace hbp::distributed
