// SPDX-License-Identifier: MIT
#include "hbp/hw/sram_model.hpp"

#include <cmath>

namespace hbp::hw {

double sram_area_um2(const SramMacro& s, const ProcessNode& node) {
  const double bits = static_cast<double>(s.words) * s.bits;
  return bits * node.sram_6t_cell_um2 * (s.dual_port ? kDualPortCellFactor : 1.0) / kArrayEfficiency;
}

double sram_access_energy_j(const SramMacro& s, const ProcessNode& node) {
  // Capacitances shrink with the linear dimension of the cell.
  const double c_scale = std::sqrt(node.sram_6t_cell_um2 / synthesis_node().sram_6t_cell_um2);
  const double c_cell = kBitlineCapPerCell180 * c_scale;
  const double v = node.vdd;
  const double bitlines = static_cast<double>(s.bits) * static_cast<double>(s.words) * c_cell * v * (kReadSwingFraction * v);
  const double wordline = static_cast<double>(s.bits) * c_cell * v * v;
  const double periphery = static_cast<double>(s.bits) * kPeripheryCapPerBit180 * c_scale * v * v;
  return bitlines + wordline + periphery;
}

}  // namespace hbp::hw
