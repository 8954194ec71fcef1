// SPDX-License-Identifier: MIT
#include "hbp/hw/many_object_model.hpp"

namespace hbp::hw {

ManyObjectModel::ManyObjectModel(const ModelConfig& cfg) : BufferModel(Design::ManyObject, cfg) {
  a_data_.resize(cfg_.m);
  b_data_.resize(cfg_.m);
}

void ManyObjectModel::load(const BoxArray& boxes) {
  // No replication: object k at address k / m of group k mod m (Table 2).
  for (std::uint32_t k = 0; k < boxes.size(); ++k) {
    buffer_.write_group(k % cfg_.m, k / cfg_.m, boxes.get(k));
  }
}

Counters ManyObjectModel::run(const BoxArray& boxes, std::vector<Pair>& pair_memory,
                              ManyObjectTrace* trace) {
  check_input(boxes);
  load(boxes);

  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::uint32_t m = cfg_.m;

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
  bool waiting_for_drain = false;

  // A row change may wait (restart cycles) until the pipeline is empty.
  const auto stalled = [&] { return waiting_for_drain && pipeline_.in_flight() > 0; };
  const auto issue = [&](std::uint64_t cycle, std::vector<Pair>& lines, Counters& k) {
    waiting_for_drain = false;
    const std::uint32_t first = row * m;
    for (std::uint32_t j = 0; j < m; ++j) {
      if (first + j < n) a_data_[j] = buffer_.read_group(j, row);
      if (b_address[j] * m + j < n) b_data_[j] = buffer_.read_group(j, b_address[j]);
    }
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
    // The row ends once comparator 0 has met object n-1.
    const std::uint32_t last_partner = b_address[selector[0]] * m + selector[0];
    if (last_partner != n - 1) {
      ++b_address[step % m];
      for (std::uint32_t c = 0; c < m; ++c) selector[c] = selector[c] + 1 == m ? 0 : selector[c] + 1;
      ++step;
      return true;
    }
    ++row;
    restart_row();
    waiting_for_drain = cfg_.row_change_drains_pipeline;
    return row * m + 1 < n;
  };
  return run_cycles(n, pair_memory, stalled, issue);
}

}  // namespace hbp::hw
