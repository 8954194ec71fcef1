// SPDX-License-Identifier: MIT
#include "hbp/hw/process_node.hpp"

#include <array>
#include <cmath>

#include "hbp/error.hpp"

namespace hbp::hw {
namespace {

// Bit cells: Intel 180 nm (Yang et al., IEDM 1998), TSMC 28 nm high-density
// cell, TSMC N5 (Yeap et al., IEDM 2019). Supplies: OSU018's Liberty
// nominal (1.8 V); the nominal core supplies of the 28 nm and 5 nm logic
// processes.
constexpr std::array<ProcessNode, 3> kNodes{{
    {"180nm", "OSU 0.18 um standard cells (synthesised, Liberty typical corner)", 1.8, 5.59},
    {"28nm", "28 nm planar HKMG (the GTX TITAN X's TSMC 28 nm), scaled", 1.0, 0.127},
    {"5nm", "5 nm FinFET (TSMC N5), scaled", 0.75, 0.021},
}};

}  // namespace

std::span<const ProcessNode> process_nodes() { return kNodes; }
const ProcessNode& synthesis_node() { return kNodes[0]; }

const ProcessNode& find_process_node(const std::string& name) {
  for (const ProcessNode& n : kNodes)
    if (name == n.name) return n;
  throw InvalidInput("unknown process node '" + name + "' (accepted: 180nm, 28nm, 5nm)");
}

double area_scale(const ProcessNode& to) { return to.sram_6t_cell_um2 / synthesis_node().sram_6t_cell_um2; }

double energy_scale(const ProcessNode& to) {
  const double v = to.vdd / synthesis_node().vdd;
  return std::sqrt(area_scale(to)) * v * v;
}

}  // namespace hbp::hw
