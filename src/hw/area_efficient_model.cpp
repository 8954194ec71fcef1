// SPDX-License-Identifier: MIT
#include "hbp/hw/area_efficient_model.hpp"

namespace hbp::hw {

AreaEfficientModel::AreaEfficientModel(const ModelConfig& cfg) : BufferModel(Design::AreaEfficient, cfg) {
  port_data_.resize(2 * cfg_.m);
}

void AreaEfficientModel::load(const BoxArray& boxes) {
  // Replication: AABB k goes to address k of every memory group, one write
  // port per AABB broadcast to all m copies.
  for (std::uint32_t k = 0; k < boxes.size(); ++k) {
    const Aabb box = boxes.get(k);
    for (std::uint32_t g = 0; g < cfg_.m; ++g) buffer_.write_group(g, k, box);
  }
}

Counters AreaEfficientModel::run(const BoxArray& boxes, std::vector<Pair>& pair_memory,
                                 AreaEfficientTrace* trace) {
  check_input(boxes);
  load(boxes);

  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::uint32_t ports = 2 * cfg_.m;
  const std::uint32_t stride = ports - 1;  // = comparisons per cycle

  // Sequencer registers: one address per port (0A, 0B, 1A, ...); port 0A is
  // the anchor, the rest cover the next 2m-1 addresses.
  std::vector<std::uint32_t> address(ports);
  std::uint32_t anchor = 0;
  for (std::uint32_t p = 0; p < ports; ++p) address[p] = p;

  const auto never_stalls = [] { return false; };
  const auto issue = [&](std::uint64_t cycle, std::vector<Pair>& lines, Counters& k) {
    // Buffer: every port with an address below n returns its group's copy.
    for (std::uint32_t p = 0; p < ports; ++p) {
      if (address[p] < n) port_data_[p] = buffer_.read_group(p / 2, address[p]);
    }
    // Compare: anchor against ports 1..2m-1; slots past n-1 are removed.
    AreaEfficientCycle* record = nullptr;
    if (trace != nullptr) {
      record = &trace->emplace_back();
      record->cycle = cycle;
      record->port_address = address;
      record->comparisons.resize(stride);
    }
    bool row_done = false;
    for (std::uint32_t s = 1; s < ports; ++s) {
      row_done |= address[s] == n - 1;
      const bool valid = address[s] < n;
      const bool hit = valid && compare_stage_overlap(port_data_[0], port_data_[s]);
      if (hit) lines.push_back({anchor, address[s]});
      if (record != nullptr) record->comparisons[s - 1] = {anchor, address[s], valid, hit};
      k.comparisons_performed += valid;
    }
    // Next addresses: new anchor once a port selected n-1, else step.
    if (!row_done) {
      for (std::uint32_t p = 1; p < ports; ++p) address[p] += stride;
      return true;
    }
    ++anchor;
    for (std::uint32_t p = 0; p < ports; ++p) address[p] = anchor + p;
    return anchor + 1 < n;
  };
  return run_cycles(n, pair_memory, never_stalls, issue);
}

}  // namespace hbp::hw
