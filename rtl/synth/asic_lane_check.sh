#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The flow on one float32 comparator (hbp_fcmp_le, a <= b): cells, area,
# input-to-output delay and energy per compare with random operands
# (activity 0.5 on every input bit), for the hand estimate from the
# Liberty tables in docs/hardware.md ("Silicon"). Same cells, ABC script,
# wire-load model and timing script (rtl/synth/sta.tcl) as rtl/synth/asic.sh;
# the comparator has no clock port, so it is timed against a virtual clock.
#   rtl/synth/asic_lane_check.sh [OUT]   (default docs/results/asic/fcmp_lane.txt)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
rtl="$(dirname "$here")"
repo="$(dirname "$rtl")"
out="${1:-$repo/docs/results/asic/fcmp_lane.txt}"
lib=/usr/share/qflow/tech/osu018/osu018_stdcells.lib
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
awk '{ print } /^library\(osu018_stdcells\)/ {
  print "  wire_load(\"hbp_local\") { resistance : 0 ; capacitance : 0.0002 ; area : 0 ; slope : 20 ;"
  print "    fanout_length(1, 20); fanout_length(2, 40); fanout_length(4, 80); fanout_length(8, 160); }"
  print "  default_wire_load : \"hbp_local\" ;" }' "$lib" > "$work/wl.lib"
printf 'set_driving_cell BUFX2\nset_load 0.02\n' > "$work/abc.sdc"
yosys -q -l "$work/yosys.log" -p "read_verilog -sv $rtl/hbp_fcmp_le.sv; synth -top hbp_fcmp_le -flatten; \
  abc -liberty $lib -D 4000 -constr $work/abc.sdc; opt_clean; tee -o $work/stat stat -liberty $lib; \
  write_verilog -noattr -noexpr $work/net.v" > /dev/null
HBP_STA_LIBERTY="$work/wl.lib" HBP_STA_NETLIST="$work/net.v" HBP_STA_TOP=hbp_fcmp_le \
  HBP_STA_PERIOD_NS=10 HBP_STA_INPUT_ACTIVITY=0.5 \
  sta -no_splash -exit "$here/sta.tcl" > "$work/sta.log" 2>&1
cells=$(awk '/Number of cells:/ { n = $NF } END { print n }' "$work/stat")
area=$(awk '/Chip area for/ { print $NF }' "$work/stat")
arrival=$(awk '/data arrival time/ { print $1; exit }' "$work/sta.log")
power=$(awk '$1 == "Total" { print $5; exit }' "$work/sta.log")
{
  echo "# one hbp_fcmp_le (float32 a <= b), OSU018, by rtl/synth/asic_lane_check.sh"
  echo "cells = $cells"
  echo "area_um2 = $area"
  echo "delay_ns = $arrival"
  echo "power_w_at_100mhz_random_operands = $power"
  awk -v p="$power" 'BEGIN { printf "energy_per_compare_pj = %.4f\n", p * 10e-9 * 1e12 }'
  echo "# cells by type"
  awk '$1 ~ /^[A-Z][A-Z0-9]*X[0-9]$/ { printf "cell_%s = %s\n", $1, $2 }' "$work/stat"
} > "$out"
cat "$out"
