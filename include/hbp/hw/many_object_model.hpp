// SPDX-License-Identifier: MIT
#pragma once
// Cycle-accurate model of the many-object microarchitecture (paper section
// 3.1.2, Tables 2 and 3). Buffer: 6m dual-port memories in m memory groups
// without replication: object k lives in group k mod m at address k / m, so
// the buffer holds depth*m objects. Sequence, per row a (A address):
// every group's A port reads address a (objects a*m .. a*m+m-1, the anchors);
// the B ports start at a+1 (group 0) and a (others) and each cycle one more
// group's B address increments, so step b presents objects a*m+b .. a*m+b+m-1.
// Reorder: 6m multiplexers in m groups; comparator k takes A data from group
// k and B data from group selector[k], the selectors starting at k+1 mod m
// and rotating by one each cycle. The row ends when comparator 0's partner is
// object n-1. Compare: 3m >= and 3m <= comparators, m six-input AND gates;
// slots touching an object >= n are discarded.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/hw/buffer_model.hpp"
#include "hbp/hw/trace.hpp"
#include "hbp/pair.hpp"

namespace hbp::hw {

class ManyObjectModel : public BufferModel {
 public:
  explicit ManyObjectModel(const ModelConfig& cfg = {});

  // Objects the buffer holds: depth * m (no replication).
  std::uint64_t capacity() const { return static_cast<std::uint64_t>(cfg_.depth) * cfg_.m; }

  // As AreaEfficientModel::run (including the pair limit).
  Counters run(const BoxArray& boxes, std::vector<Pair>& pair_memory,
               ManyObjectTrace* trace = nullptr);

 private:
  void load(const BoxArray& boxes);

  std::vector<AabbWords> a_data_, b_data_;  // m words each, read this cycle
};

}  // namespace hbp::hw
