// SPDX-License-Identifier: MIT
#pragma once
// Cell engines backed by the Verilated RTL (rtl/area_efficient.sv and
// rtl/many_object.sv, m = 16, memory depth 1024 as on the paper's FPGA):
//   "rtl-ae"  area-efficient, capacity 1024 boxes
//   "rtl-mo"  many-object,    capacity 16,384 boxes
// Every find_pairs call clocks the RTL through load, sequence and drain, so
// it is slow (verification, not speed); the reported cycles are the RTL's
// own cycle counter. Available when the build found Verilator (target
// hbp_rtl, HBP_HAVE_RTL).
namespace hbp::rtl {

// Registers "rtl-ae" and "rtl-mo" with hbp::register_cell_engine. Idempotent.
void register_rtl_engines();

}  // namespace hbp::rtl
