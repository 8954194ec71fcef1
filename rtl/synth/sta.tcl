# SPDX-License-Identifier: MIT
# OpenSTA timing and power of one mapped netlist: the one script behind every
# run of rtl/synth/asic.sh (a design at one m) and rtl/synth/asic_lane_check.sh
# (one comparator). A run's values come from the environment, and the log
# opens with them (key = value), so a log says what it was timed with:
#   HBP_STA_LIBERTY          Liberty with the wire-load model
#   HBP_STA_NETLIST          mapped Verilog netlist
#   HBP_STA_TOP              its top module
#   HBP_STA_PERIOD_NS        clock period; power is reported at this clock
#   HBP_STA_INPUT_ACTIVITY   toggles per clock on the data inputs
#   HBP_STA_GLOBAL_ACTIVITY  toggles per clock on every other net (optional:
#                            unset, OpenSTA propagates the input activity)
# A design with a port clk is clocked by it; one without (pure logic) is
# timed input to output against a virtual clock of the same period.
# Inputs arrive at the clock edge from a BUFX2 and outputs drive 0.02 pF,
# the loads ABC buffered against (the flows' abc.sdc).

proc run_value {name} {
  if {![info exists ::env($name)] || $::env($name) eq ""} {
    puts stderr "sta.tcl: $name is not set"
    exit 2
  }
  return $::env($name)
}

set liberty [run_value HBP_STA_LIBERTY]
set netlist [run_value HBP_STA_NETLIST]
set top [run_value HBP_STA_TOP]
set period_ns [run_value HBP_STA_PERIOD_NS]
set input_activity [run_value HBP_STA_INPUT_ACTIVITY]
set global_activity ""
if {[info exists ::env(HBP_STA_GLOBAL_ACTIVITY)]} {
  set global_activity $::env(HBP_STA_GLOBAL_ACTIVITY)
}
puts "liberty = $liberty"
puts "netlist = $netlist"
puts "top = $top"
puts "clock_period_ns = $period_ns"
if {$global_activity ne ""} { puts "global_activity = $global_activity" }
puts "input_activity = $input_activity"

read_liberty $liberty
read_verilog $netlist
link_design $top
set clock_port [get_ports -quiet clk]
if {[llength $clock_port] > 0} {
  create_clock -name clk -period $period_ns $clock_port
  set inputs [delete_from_list [all_inputs] $clock_port]
} else {
  create_clock -name clk -period $period_ns
  set inputs [all_inputs]
}
set_input_delay 0 -clock clk $inputs
set_output_delay 0 -clock clk [all_outputs]
set_driving_cell -lib_cell BUFX2 $inputs
set_load 0.02 [all_outputs]
report_checks -path_delay max -digits 3 -fields {fanout cap slew}
report_worst_slack -digits 4
if {$global_activity ne ""} {
  set_power_activity -global -activity $global_activity
}
set_power_activity -input -activity $input_activity
report_power -digits 6
