// SPDX-License-Identifier: MIT
#pragma once
// One configuration's report from the standard-cell flow (rtl/synth/asic.sh):
// "key = value" lines. The logic only: memories are counted, not synthesised
// (see sram_model.hpp).
#include <cstdint>
#include <string>
#include <string_view>

#include "hbp/hw/design.hpp"

namespace hbp::hw {

struct AsicReport {
  Design design = Design::AreaEfficient;
  std::uint32_t m = 0, depth = 0, pair_rows = 0, lanes = 0;
  std::string rtl_sha256;        // of the RTL sources it was made from
  double logic_area_um2 = 0;     // standard cells, 180 nm
  std::uint64_t cells = 0;       // standard cells
  std::uint64_t flip_flops = 0;
  std::uint32_t memories = 0;    // $mem cells left for the SRAM model
  double clock_period_ns = 0;    // clock the power was reported at
  double worst_slack_ns = 0;     // at that clock
  std::string critical_path_from, critical_path_to;  // nets of its end registers
  double power_total_w = 0;      // OpenSTA, at that clock and the activities
  double power_leakage_w = 0;
  double global_activity = 0;    // toggles per clock given to OpenSTA
  double input_activity = 0;

  double critical_path_ns() const { return clock_period_ns - worst_slack_ns; }
  double fmax_hz() const { return 1e9 / critical_path_ns(); }
  // Energy of the logic per clock cycle at the stated activities: dynamic
  // energy does not depend on the clock, so P x period at any clock.
  double logic_energy_per_cycle_j() const { return power_total_w * clock_period_ns * 1e-9; }
};

// `name` names the report in error messages; throws InvalidInput naming the
// missing or malformed key.
AsicReport parse_asic_report(std::string_view text, const std::string& name);

}  // namespace hbp::hw
