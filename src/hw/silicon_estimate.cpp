// SPDX-License-Identifier: MIT
#include "hbp/hw/silicon_estimate.hpp"

#include <bit>

#include "hbp/hw/model_config.hpp"

namespace hbp::hw {
namespace {

std::uint32_t ceil_log2(std::uint64_t x) {
  std::uint32_t b = 0;
  while ((std::uint64_t{1} << b) < x) ++b;
  return b;
}

}  // namespace

MemoryInventory memory_inventory(Design d, std::uint32_t m, std::uint32_t depth, std::uint32_t pair_rows) {
  const bool ae = d == Design::AreaEfficient;
  const std::uint64_t capacity = ae ? depth : std::uint64_t{depth} * m;
  const std::uint32_t index_bits = capacity > 1 ? ceil_log2(capacity) : 1;  // the RTL's PW
  MemoryInventory inv;
  inv.buffer = {depth, 32, true};
  inv.buffer_count = 6 * m;
  inv.pair_bank = {pair_rows, 2 * index_bits, true};
  inv.pair_banks = ae ? 2 * m - 1 : m;
  return inv;
}

SiliconArea silicon_area(const AsicReport& r, const ProcessNode& node) {
  const MemoryInventory inv = memory_inventory(r.design, r.m, r.depth, r.pair_rows);
  SiliconArea a;
  a.logic_um2 = r.logic_area_um2 * area_scale(node);
  a.memory_um2 = inv.buffer_count * sram_area_um2(inv.buffer, node) + inv.pair_banks * sram_area_um2(inv.pair_bank, node);
  return a;
}

CycleActivity cycle_activity(const Counters& k, std::uint32_t lanes, double toggle_rate) {
  CycleActivity a;
  const double total = static_cast<double>(k.cycles.total());
  if (total == 0) return a;
  a.load_fraction = static_cast<double>(k.cycles.load) / total;
  a.sequence_fraction = static_cast<double>(k.cycles.sequence) / total;
  a.pairs_per_cycle = static_cast<double>(k.pairs_written) / total;
  const double busy = static_cast<double>(k.comparisons_performed) / (total * lanes);
  a.datapath_activity = busy * toggle_rate;
  a.input_activity = a.load_fraction * toggle_rate;
  return a;
}

double data_toggle_rate(const BoxArray& boxes) {
  if (boxes.size() < 2) return 0;
  std::uint64_t flips = 0;
  for (int l = 0; l < 6; ++l) {
    const float* v = l < 3 ? boxes.min(l) : boxes.max(l - 3);
    for (std::size_t i = 1; i < boxes.size(); ++i)
      flips += std::popcount(std::bit_cast<std::uint32_t>(v[i]) ^ std::bit_cast<std::uint32_t>(v[i - 1]));
  }
  return static_cast<double>(flips) / (6.0 * 32.0 * static_cast<double>(boxes.size() - 1));
}

EnergyPerCycle energy_per_cycle(const AsicReport& r, const CycleActivity& a, const ProcessNode& node) {
  const MemoryInventory inv = memory_inventory(r.design, r.m, r.depth, r.pair_rows);
  const double e_buffer = sram_access_energy_j(inv.buffer, node);
  const double e_pair = sram_access_energy_j(inv.pair_bank, node);
  const double reads = a.sequence_fraction * 2.0 * inv.buffer_count;
  const double per_box = r.design == Design::AreaEfficient ? inv.buffer_count : 6.0;
  const double writes = a.load_fraction * ModelConfig{}.load_aabbs_per_cycle * per_box;
  EnergyPerCycle e;
  e.logic_j = r.logic_energy_per_cycle_j() * energy_scale(node);
  e.memory_j = (reads + writes) * e_buffer + a.pairs_per_cycle * 2.0 * e_pair;
  return e;
}

}  // namespace hbp::hw
