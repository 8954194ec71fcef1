#include "hbp/hw/area_efficient_model.hpp"

#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/buffer_input_checks.hpp"
#include "hbp/hw/pair_limit_check.hpp"

namespace hbp::hw {

AreaEfficientModel::AreaEfficientModel(const ModelConfig& cfg) : cfg_(cfg) {
  validate(cfg_);
  buffer_.configure(cfg_.m, cfg_.depth);
  port_data_.resize(2 * cfg_.m);
}

std::uint32_t AreaEfficientModel::pipeline_depth() const {
  return hw::pipeline_depth(Design::AreaEfficient, cfg_);
}

Resources AreaEfficientModel::resources() const {
  return hw::resources(Design::AreaEfficient, cfg_);
}

CycleBreakdown AreaEfficientModel::analytic_cycles(std::uint64_t n) const {
  return hw::analytic_cycles(Design::AreaEfficient, n, cfg_);
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
  check_buffer_input(Design::AreaEfficient, cfg_, boxes);
  load(boxes);
  pipeline_.configure(pipeline_depth());

  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::size_t base = pair_memory.size();
  const std::uint32_t ports = 2 * cfg_.m;
  const std::uint32_t stride = ports - 1;  // = comparisons per cycle
  Counters k;
  std::uint64_t cycle = 0;
  if (cfg_.count_load) {
    const std::uint32_t rate = load_aabbs_per_cycle(Design::AreaEfficient, cfg_);
    for (std::uint32_t written = 0; written < n; written += rate) ++cycle;
    k.cycles.load = cycle;
  }

  // Sequencer registers: one address per port (0A, 0B, 1A, ...); port 0A is
  // the anchor, the rest cover the next 2m-1 addresses.
  std::vector<std::uint32_t> address(ports);
  std::uint32_t anchor = 0;
  for (std::uint32_t p = 0; p < ports; ++p) address[p] = p;
  bool active = n >= 2;

  while (active || pipeline_.in_flight() > 0) {
    ++cycle;
    if (!active) {
      ++k.cycles.drain;
    } else {
      ++k.cycles.sequence;
      // Buffer: every port with an address below n returns its group's copy.
      for (std::uint32_t p = 0; p < ports; ++p) {
        if (address[p] < n) port_data_[p] = buffer_.read_group(p / 2, address[p]);
      }
      // Compare: anchor against ports 1..2m-1; slots past n-1 are removed.
      std::vector<Pair>& lines = pipeline_.issue(cycle);
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
      k.comparator_slots += stride;
      // Next addresses: new anchor once a port selected n-1, else step.
      if (row_done) {
        ++anchor;
        active = anchor + 1 < n;
        for (std::uint32_t p = 0; p < ports; ++p) address[p] = anchor + p;
      } else {
        for (std::uint32_t p = 1; p < ports; ++p) address[p] += stride;
      }
    }
    k.pairs_written += pipeline_.retire(cycle, pair_memory);
    check_pair_limit(pair_memory.size() - base, pair_limit_, n);
  }
  k.comparisons_discarded = k.comparator_slots - k.comparisons_performed;
  return k;
}

}  // namespace hbp::hw
