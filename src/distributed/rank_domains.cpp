// SPDX-License-Identifier: MIT
#include "distributed/rank_domains.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

namespace hbp::distributed {
namespace {

// Order-preserving map of finite floats to unsigned integers: a < b (IEEE)
// implies key(a) < key(b), so a bisection on keys is a bisection on floats.
std::uint32_t key_of(float f) {
  const auto u = std::bit_cast<std::uint32_t>(f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
float float_of(std::uint32_t k) {
  const std::uint32_t u = (k & 0x80000000u) ? (k & 0x7fffffffu) : ~k;
  return std::bit_cast<float>(u);
}

}  // namespace

void RankDomains::build(MPI_Comm comm, const float* cx, const float* cy, const float* cz, std::size_t n) {
  int p = 1;
  MPI_Comm_size(comm, &p);
  ranks_ = p;
  nodes_.assign(1, Node{});
  nodes_[0].rank_lo = 0;
  nodes_[0].rank_hi = p;
  const float* c[3] = {cx, cy, cz};
  std::vector<int> node_of(n, 0);
  std::vector<int> active;
  if (p > 1) active.push_back(0);
  std::vector<int> slot;
  std::vector<std::uint64_t> counts, total;
  std::vector<float> lo_box, hi_box, lo_all, hi_all;
  std::vector<std::uint64_t> target, node_total;
  std::vector<std::uint32_t> key_lo, key_hi;
  while (!active.empty()) {
    const std::size_t m = active.size();
    slot.assign(nodes_.size(), -1);
    for (std::size_t s = 0; s < m; ++s) slot[static_cast<std::size_t>(active[s])] = static_cast<int>(s);
    // Object count and centre bounds of every active node, over all ranks.
    counts.assign(m, 0);
    lo_box.assign(3 * m, std::numeric_limits<float>::infinity());
    hi_box.assign(3 * m, -std::numeric_limits<float>::infinity());
    for (std::size_t i = 0; i < n; ++i) {
      const int s = slot[static_cast<std::size_t>(node_of[i])];
      if (s < 0) continue;
      ++counts[static_cast<std::size_t>(s)];
      for (int k = 0; k < 3; ++k) {
        float& lo = lo_box[3 * static_cast<std::size_t>(s) + static_cast<std::size_t>(k)];
        float& hi = hi_box[3 * static_cast<std::size_t>(s) + static_cast<std::size_t>(k)];
        lo = std::min(lo, c[k][i]);
        hi = std::max(hi, c[k][i]);
      }
    }
    total.resize(m);
    lo_all.resize(3 * m);
    hi_all.resize(3 * m);
    MPI_Allreduce(counts.data(), total.data(), static_cast<int>(m), MPI_UINT64_T, MPI_SUM, comm);
    MPI_Allreduce(lo_box.data(), lo_all.data(), static_cast<int>(3 * m), MPI_FLOAT, MPI_MIN, comm);
    MPI_Allreduce(hi_box.data(), hi_all.data(), static_cast<int>(3 * m), MPI_FLOAT, MPI_MAX, comm);
    target.resize(m);
    node_total = total;
    key_lo.resize(m);
    key_hi.resize(m);
    for (std::size_t s = 0; s < m; ++s) {
      Node& node = nodes_[static_cast<std::size_t>(active[s])];
      const auto k = static_cast<std::uint64_t>(node.rank_hi - node.rank_lo);
      const std::uint64_t k_left = k / 2;
      target[s] = (total[s] * k_left + k / 2) / k;  // proportional, rounded
      int axis = 0;
      float spread = -1;
      for (int a = 0; a < 3; ++a) {
        const float e = hi_all[3 * s + static_cast<std::size_t>(a)] - lo_all[3 * s + static_cast<std::size_t>(a)];
        if (e > spread) spread = e, axis = a;
      }
      node.axis = axis;
      if (total[s] == 0) {  // nothing to balance: any plane inside the node
        const float lo = std::max(node.region.lo[axis], -std::numeric_limits<float>::max());
        const float hi = std::min(node.region.hi[axis], std::numeric_limits<float>::max());
        key_lo[s] = key_hi[s] = key_of(std::clamp(0.0f, lo, hi));
      } else {
        key_lo[s] = key_of(lo_all[3 * s + static_cast<std::size_t>(axis)]);
        key_hi[s] = key_of(hi_all[3 * s + static_cast<std::size_t>(axis)]) + 1;  // #{c < float(key_hi)} = total
      }
    }
    // Bisection on the keys of all active nodes at once: the smallest key K
    // with #{centre < float(K)} > target; the split is then float(K - 1), the
    // smallest centre of the right side, so planes lie on object centres
    // (and the tests meet boxes touching them). One allreduce per step, <= 32
    // steps.
    for (;;) {
      bool open = false;
      for (std::size_t s = 0; s < m; ++s) open |= key_lo[s] < key_hi[s];
      if (!open) break;
      counts.assign(m, 0);
      for (std::size_t i = 0; i < n; ++i) {
        const int s = slot[static_cast<std::size_t>(node_of[i])];
        if (s < 0 || key_lo[static_cast<std::size_t>(s)] >= key_hi[static_cast<std::size_t>(s)]) continue;
        const std::size_t us = static_cast<std::size_t>(s);
        const std::uint32_t mid = key_lo[us] + (key_hi[us] - key_lo[us]) / 2;
        counts[us] += c[nodes_[static_cast<std::size_t>(active[us])].axis][i] < float_of(mid) ? 1 : 0;
      }
      MPI_Allreduce(counts.data(), total.data(), static_cast<int>(m), MPI_UINT64_T, MPI_SUM, comm);
      for (std::size_t s = 0; s < m; ++s) {
        if (key_lo[s] >= key_hi[s]) continue;
        const std::uint32_t mid = key_lo[s] + (key_hi[s] - key_lo[s]) / 2;
        if (total[s] > target[s])
          key_hi[s] = mid;
        else
          key_lo[s] = mid + 1;
      }
    }
    // Children: left gets floor(k/2) ranks and the centres below the split.
    std::vector<int> next;
    for (std::size_t s = 0; s < m; ++s) {
      const int id = active[s];
      const int axis = nodes_[static_cast<std::size_t>(id)].axis;
      // target == total: no key passes it and all objects go left.
      const float split = float_of(target[s] >= node_total[s] ? key_lo[s] : key_lo[s] - 1);
      Node left, right;
      const Node parent = nodes_[static_cast<std::size_t>(id)];
      left.rank_lo = parent.rank_lo;
      left.rank_hi = right.rank_lo = parent.rank_lo + (parent.rank_hi - parent.rank_lo) / 2;
      right.rank_hi = parent.rank_hi;
      left.region = right.region = parent.region;
      left.region.hi[axis] = split;
      right.region.lo[axis] = split;
      const int li = static_cast<int>(nodes_.size());
      nodes_.push_back(left);
      nodes_.push_back(right);
      Node& node = nodes_[static_cast<std::size_t>(id)];
      node.split = split;
      node.child[0] = li;
      node.child[1] = li + 1;
      if (left.rank_hi - left.rank_lo > 1) next.push_back(li);
      if (right.rank_hi - right.rank_lo > 1) next.push_back(li + 1);
    }
    for (std::size_t i = 0; i < n; ++i) {
      const Node& node = nodes_[static_cast<std::size_t>(node_of[i])];
      if (node.axis < 0 || node.child[0] < 0) continue;
      node_of[i] = node.child[c[node.axis][i] < node.split ? 0 : 1];
    }
    active.swap(next);
  }
  // Leaves: mark them and record each rank's region.
  regions_.assign(static_cast<std::size_t>(p), CellRegion::everything());
  for (Node& node : nodes_) {
    if (node.child[0] >= 0) continue;
    node.axis = -1;
    regions_[static_cast<std::size_t>(node.rank_lo)] = node.region;
  }
}

int RankDomains::owner(float x, float y, float z) const {
  const float p[3] = {x, y, z};
  int id = 0;
  while (nodes_[static_cast<std::size_t>(id)].axis >= 0) {
    const Node& node = nodes_[static_cast<std::size_t>(id)];
    id = node.child[p[node.axis] < node.split ? 0 : 1];
  }
  return nodes_[static_cast<std::size_t>(id)].rank_lo;
}

void RankDomains::ranks_reaching(const Aabb& box, std::vector<int>& out) const {
  // The closed box meets the closure of {x < split} when min <= split and the
  // closure of {x >= split} when max >= split; a box touching the plane goes
  // both ways (docs/distributed.md, ghost rule).
  stack_.assign(1, 0);
  while (!stack_.empty()) {
    const Node& node = nodes_[static_cast<std::size_t>(stack_.back())];
    stack_.pop_back();
    if (node.axis < 0) {
      out.push_back(node.rank_lo);
      continue;
    }
    if (box.max[node.axis] >= node.split) stack_.push_back(node.child[1]);
    if (box.min[node.axis] <= node.split) stack_.push_back(node.child[0]);
  }
}

}  // namespace hbp::distributed
