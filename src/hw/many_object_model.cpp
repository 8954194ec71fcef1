#include "hbp/hw/many_object_model.hpp"

#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/buffer_input_checks.hpp"
#include "hbp/hw/pair_limit_check.hpp"

namespace hbp::hw {

ManyObjectModel::ManyObjectModel(const ModelConfig& cfg) : cfg_(cfg) {
  validate(cfg_);
  buffer_.configure(cfg_.m, cfg_.depth);
  a_data_.resize(cfg_.m);
  b_data_.resize(cfg_.m);
}

std::uint32_t ManyObjectModel::pipeline_depth() const {
  return hw::pipeline_depth(Design::ManyObject, cfg_);
}

Resources ManyObjectModel::resources() const { return hw::resources(Design::ManyObject, cfg_); }

CycleBreakdown ManyObjectModel::analytic_cycles(std::uint64_t n) const {
  return hw::analytic_cycles(Design::ManyObject, n, cfg_);
}

void ManyObjectModel::load(const BoxArray& boxes) {
  // No replication: object k at address k / m of group k mod m (Table 2).
  for (std::uint32_t k = 0; k < boxes.size(); ++k) {
    buffer_.write_group(k % cfg_.m, k / cfg_.m, boxes.get(k));
  }
}

Counters ManyObjectModel::run(const BoxArray& boxes, std::vector<Pair>& pair_memory,
                              ManyObjectTrace* trace) {
  check_buffer_input(Design::ManyObject, cfg_, boxes);
  load(boxes);
  pipeline_.configure(pipeline_depth());

  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::size_t base = pair_memory.size();
  const std::uint32_t m = cfg_.m;
  Counters k;
  std::uint64_t cycle = 0;
  if (cfg_.count_load) {
    const std::uint32_t rate = load_aabbs_per_cycle(Design::ManyObject, cfg_);
    for (std::uint32_t written = 0; written < n; written += rate) ++cycle;
    k.cycles.load = cycle;
  }

  // Sequencer registers. `row` is every A port's address; b_address[j] is
  // group j's B port; selector[c] is comparator c's multiplexer select.
  std::uint32_t row = 0;
  std::uint32_t step = 1;
  std::vector<std::uint32_t> b_address(m), selector(m);
  const auto restart_row = [&] {
    for (std::uint32_t j = 0; j < m; ++j) {
      b_address[j] = j == 0 ? row + 1 : row;
      selector[j] = (j + 1) % m;
    }
    step = 1;
  };
  restart_row();
  bool active = n >= 2;
  bool waiting_for_drain = false;

  while (active || pipeline_.in_flight() > 0) {
    ++cycle;
    if (!active) {
      ++k.cycles.drain;
    } else if (waiting_for_drain && pipeline_.in_flight() > 0) {
      ++k.cycles.restart;
    } else {
      waiting_for_drain = false;
      ++k.cycles.sequence;
      const std::uint32_t first = row * m;
      for (std::uint32_t j = 0; j < m; ++j) {
        if (first + j < n) a_data_[j] = buffer_.read_group(j, row);
        if (b_address[j] * m + j < n) b_data_[j] = buffer_.read_group(j, b_address[j]);
      }
      std::vector<Pair>& lines = pipeline_.issue(cycle);
      ManyObjectCycle* record = nullptr;
      if (trace != nullptr) {
        record = &trace->emplace_back();
        record->cycle = cycle;
        record->a_address.assign(m, row);
        record->b_address = b_address;
        record->selector = selector;
        record->a_object.resize(m);
        record->b_object.resize(m);
        for (std::uint32_t j = 0; j < m; ++j) {
          record->a_object[j] = first + j;
          record->b_object[j] = b_address[j] * m + j;
        }
        record->comparisons.resize(m);
      }
      // Reorder + compare: comparator c pairs A group c with B group selector[c].
      for (std::uint32_t c = 0; c < m; ++c) {
        const std::uint32_t g = selector[c];
        const std::uint32_t anchor = first + c;
        const std::uint32_t partner = b_address[g] * m + g;
        const bool valid = partner < n;
        const bool hit = valid && compare_stage_overlap(a_data_[c], b_data_[g]);
        if (hit) lines.push_back({anchor, partner});
        if (record != nullptr) record->comparisons[c] = {anchor, partner, valid, hit};
        k.comparisons_performed += valid;
      }
      k.comparator_slots += m;
      // The row ends once comparator 0 has met object n-1.
      const std::uint32_t last_partner = b_address[selector[0]] * m + selector[0];
      if (last_partner == n - 1) {
        ++row;
        active = row * m + 1 < n;
        restart_row();
        waiting_for_drain = cfg_.row_change_drains_pipeline;
      } else {
        ++b_address[step % m];
        for (std::uint32_t c = 0; c < m; ++c) selector[c] = selector[c] + 1 == m ? 0 : selector[c] + 1;
        ++step;
      }
    }
    k.pairs_written += pipeline_.retire(cycle, pair_memory);
    check_pair_limit(pair_memory.size() - base, pair_limit_, n);
  }
  k.comparisons_discarded = k.comparator_slots - k.comparisons_performed;
  return k;
}

}  // namespace hbp::hw
