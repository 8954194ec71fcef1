// SPDX-License-Identifier: MIT
#pragma once
// Analytic SRAM model for the memories the standard-cell flow does not
// synthesise (no SRAM compiler exists for OSU018): the 6m dual-port buffer
// memories and the pair-memory banks. Area = bits x bit cell x port factor /
// array efficiency; energy per access = bit-line charge of the accessed
// word's columns (C_bl V_dd dV) + word line + periphery (after Rabaey,
// Chandrakasan and Nikolic, Digital Integrated Circuits, 2nd ed., ch. 12).
// Parameters (docs/hardware.md lists them) are defaults, not measured.
#include <cstdint>

#include "hbp/hw/process_node.hpp"

namespace hbp::hw {

struct SramMacro {
  std::uint64_t words = 0;
  std::uint32_t bits = 0;   // per word
  bool dual_port = true;    // two address ports (the buffer's A and B; a bank's write and read)
};

// Stated defaults of the model.
inline constexpr double kDualPortCellFactor = 2.0;    // two word lines and bit-line pairs vs 6T
inline constexpr double kArrayEfficiency = 0.7;       // cell area / macro area
inline constexpr double kBitlineCapPerCell180 = 2e-15;  // F per cell on a bit line at 180 nm
inline constexpr double kReadSwingFraction = 0.1;     // bit-line swing / Vdd on a read
inline constexpr double kPeripheryCapPerBit180 = 10e-15;  // F per accessed bit: decoder, sense, I/O

double sram_area_um2(const SramMacro& s, const ProcessNode& node);
// One word read (or written: taken as equal, full-swing writes of a word
// are in the periphery term).
double sram_access_energy_j(const SramMacro& s, const ProcessNode& node);

}  // namespace hbp::hw
