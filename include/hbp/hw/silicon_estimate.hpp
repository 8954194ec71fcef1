// SPDX-License-Identifier: MIT
#pragma once
// Area and energy of one accelerator on silicon: the standard-cell logic from
// the flow's report (AsicReport) plus the memories from the analytic SRAM
// model, at the synthesised node or scaled to another (process_node.hpp).
#include <cstdint>

#include "hbp/box_array.hpp"
#include "hbp/hw/asic_report.hpp"
#include "hbp/hw/counters.hpp"
#include "hbp/hw/process_node.hpp"
#include "hbp/hw/sram_model.hpp"

namespace hbp::hw {

// The memories the flow leaves to the SRAM model: 6m dual-port buffer
// memories of depth x 32 bits, and one bank per compare lane of pair_rows
// lines of two object indices (one write and one read port).
struct MemoryInventory {
  SramMacro buffer;
  std::uint32_t buffer_count = 0;
  SramMacro pair_bank;
  std::uint32_t pair_banks = 0;
  std::uint32_t count() const { return buffer_count + pair_banks; }
};
MemoryInventory memory_inventory(Design d, std::uint32_t m, std::uint32_t depth, std::uint32_t pair_rows);

struct SiliconArea {
  double logic_um2 = 0, memory_um2 = 0;
  double total_um2() const { return logic_um2 + memory_um2; }
  double memory_share() const { return memory_um2 / total_um2(); }
};
SiliconArea silicon_area(const AsicReport& r, const ProcessNode& node);

// What a cycle does on average, from the models' counters on a cell: the
// share of load and sequence cycles and pair lines per cycle (memory
// accesses), and the datapath's toggles per clock.
struct CycleActivity {
  double load_fraction = 0;
  double sequence_fraction = 0;
  double pairs_per_cycle = 0;
  double datapath_activity = 0;  // lane busy share x data toggle rate
  double input_activity = 0;     // load share x data toggle rate
};
CycleActivity cycle_activity(const Counters& k, std::uint32_t lanes, double data_toggle_rate);

// Mean share of the 32 bits of a coordinate that change between consecutive
// boxes (index order, as the buffer memories hold and stream them), over
// the six coordinates: the toggle rate of a memory read port's data.
double data_toggle_rate(const BoxArray& boxes);

struct EnergyPerCycle {
  double logic_j = 0, memory_j = 0;
  double total_j() const { return logic_j + memory_j; }
  double memory_share() const { return memory_j / total_j(); }
};
// Buffer: both ports of every memory read in a sequence cycle (an upper
// bound); a load cycle writes ModelConfig's load_aabbs_per_cycle boxes, each
// into all 6m memories (area-efficient: every group holds every box) or into
// 6 (many-object: a box lives in one group). Each pair line is written once
// and read once.
EnergyPerCycle energy_per_cycle(const AsicReport& r, const CycleActivity& a, const ProcessNode& node);

// The GTX TITAN X's die (GM200, TSMC 28 nm).
inline constexpr double kTitanXDieMm2 = 601.0;

}  // namespace hbp::hw
