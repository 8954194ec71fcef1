#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Standard-cell flow of both microarchitectures: Yosys + ABC onto the OSU
# 0.18 um library (qflow-tech-osu018), OpenSTA for the critical path and the
# power at a stated clock. Memories are not synthesised: the 6m buffer
# memories and the pair-memory banks stay Yosys $mem cells, are counted, and
# are removed before timing; their area and energy come from the analytic
# SRAM model (src/hw/sram_model.cpp), which `hbp hw asic` adds.
#
#   rtl/synth/asic.sh [--designs "ae mo"] [--m "1 2 4 8 16"] [--depth 1024]
#                     [--out DIR] [--activities FILE] [--sta-only]
#
# Writes one report per configuration, DIR/<design>_m<m>.txt (key = value
# lines read by `hbp hw asic`), and keeps the Yosys script, log (gzip) and
# cell statistics and the OpenSTA report in DIR/logs/. Timing and power run
# rtl/synth/sta.tcl, one script for every configuration: its values come from
# the environment and open the report (<tag>.sta.log). Every report carries
# rtl_sha256, the hash of the RTL sources it was made from, so a test can
# tell a report that no longer matches the RTL.
# --sta-only reuses the netlists of an earlier run (DIR/logs/*.netlist.v) and
# redoes timing and power only (new activities). Default DIR:
# docs/results/asic. Slow (minutes per m = 16 design): not part
# of `make test`; the reports are checked in.
#
# Activities (toggles per clock, OpenSTA set_power_activity) come from FILE
# (default: DIR/activities.txt, written by `hbp hw activity`): measured
# from the C++ models on cells of the paper scene. Signals without a
# measured class get the stated default (global_activity in that file).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
rtl="$(dirname "$here")"
repo="$(dirname "$rtl")"

designs="ae mo"
ms="1 2 4 8 16"
depth=1024
pair_rows=512
out="$repo/docs/results/asic"
activities=""
sta_only=0
while [ $# -gt 0 ]; do
  case "$1" in
    --designs) designs="$2"; shift 2 ;;
    --m) ms="$2"; shift 2 ;;
    --depth) depth="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --activities) activities="$2"; shift 2 ;;
    --sta-only) sta_only=1; shift ;;
    *) echo "asic.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -n "$activities" ] || activities="$out/activities.txt"

lib=/usr/share/qflow/tech/osu018/osu018_stdcells.lib
need=""
command -v yosys > /dev/null || need="$need yosys"
command -v sta > /dev/null || need="$need opensta"
[ -f "$lib" ] || need="$need qflow-tech-osu018"
if [ -n "$need" ]; then
  echo "asic.sh: installing$need" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $need > /dev/null
fi
if [ ! -f "$activities" ]; then
  echo "asic.sh: no activity file $activities (make it with: hbp hw activity > $activities)" >&2
  exit 2
fi
act() {  # key -> value from the activity file
  local v
  v=$(awk -v k="$1" '$1 == k && $2 == "=" { print $3 }' "$activities")
  [ -n "$v" ] || { echo "asic.sh: $activities has no $1" >&2; exit 2; }
  echo "$v"
}

mkdir -p "$out/logs"
common="hbp_fcmp_le.sv hbp_box_overlap.sv hbp_dpram.sv hbp_delay.sv hbp_pair_memory.sv hbp_run_control.sv"
sources() {
  if [ "$1" = ae ]; then echo "area_efficient.sv hbp_ae_sequencer.sv $common";
  else echo "many_object.sv hbp_mo_sequencer.sv $common"; fi
}
top() { if [ "$1" = ae ]; then echo hbp_area_efficient; else echo hbp_many_object; fi; }
# The hash `hbp hw asic` and its test recompute: sha256 over the sources of
# both designs, in this order (rtl/synth/asic_sources.txt lists them), their
# licence lines left out (they change no logic).
rtl_sha=$(cd "$rtl" && cat $(cat "$here/asic_sources.txt") | grep -v '^// SPDX-License-Identifier:' | sha256sum | cut -d' ' -f1)

# Wire-load model: OSU018's Liberty has none, so a copy of it gains one.
# 0.2 fF/um of routed wire and 20 um per fanout (a short local net at
# 0.18 um); stated defaults, not extracted from a layout.
wl_lib="$out/logs/osu018_wl.lib"
awk '{ print } /^library\(osu018_stdcells\)/ {
  print "  wire_load(\"hbp_local\") { resistance : 0 ; capacitance : 0.0002 ; area : 0 ; slope : 20 ;"
  print "    fanout_length(1, 20); fanout_length(2, 40); fanout_length(4, 80); fanout_length(8, 160); }"
  print "  default_wire_load : \"hbp_local\" ;" }' "$lib" > "$wl_lib"

period_ns=10   # power is reported at 100 MHz; energy per cycle is P * period
for d in $designs; do
  for m in $ms; do
    tag="${d}_m${m}"
    log="$out/logs/$tag"
    t=$(top "$d")
    lanes=$([ "$d" = ae ] && echo $((2 * m - 1)) || echo "$m")
    # ABC's delay target and the loads it buffers against (set_driving_cell,
    # set_load): without them high-fanout nets stay unbuffered.
    cat > "$log.abc.sdc" <<EOF
set_driving_cell BUFX2
set_load 0.02
EOF
    # The netlist is written for OpenSTA's Verilog reader, which takes no
    # concatenation on the left of an assign: ports split into bits and the
    # aliases between them purged, so every output is connected and timed.
    cat > "$log.ys" <<EOF
read_verilog -sv $(for f in $(sources "$d"); do printf '%s ' "$rtl/$f"; done)
hierarchy -top $t -chparam M $m -chparam DEPTH $depth -chparam PAIR_ROWS $pair_rows
synth -top $t -flatten -run begin:fine
opt -fast -full
techmap
opt -fast
tee -o $log.memories select -count t:\$mem_v2
dfflibmap -liberty $lib
abc -liberty $lib -D 4000 -constr $log.abc.sdc
opt_clean
tee -o $log.stat stat -liberty $lib
delete t:\$mem_v2
splitnets -ports
opt_clean -purge
write_verilog -noattr -noexpr $log.netlist.v
EOF
    if [ "$sta_only" = 0 ] || [ ! -f "$log.netlist.v" ]; then
      t0=$SECONDS
      yosys -q -l "$log.yosys.log" -s "$log.ys" > /dev/null 2>&1 || { echo "asic.sh: yosys failed, see $log.yosys.log" >&2; exit 1; }
      echo $((SECONDS - t0)) > "$log.seconds"
      gzip -9 -f "$log.yosys.log"   # kept as data, ~1 MB a run uncompressed
    fi
    synth_s=$(cat "$log.seconds")

    global_activity=$(act ${d}_global_activity)
    input_activity=$(act ${d}_input_activity)
    HBP_STA_LIBERTY="$wl_lib" HBP_STA_NETLIST="$log.netlist.v" HBP_STA_TOP="$t" \
      HBP_STA_PERIOD_NS="$period_ns" HBP_STA_GLOBAL_ACTIVITY="$global_activity" \
      HBP_STA_INPUT_ACTIVITY="$input_activity" \
      sta -no_splash -exit "$here/sta.tcl" > "$log.sta.log" 2>&1 || { echo "asic.sh: sta failed, see $log.sta.log" >&2; exit 1; }

    area=$(awk '/Chip area for/ { print $NF }' "$log.stat" | tail -1)
    cells=$(awk '/Number of cells:/ { n = $NF } $1 == "$mem_v2" { mm = $2 } END { print n - mm }' "$log.stat")
    ffs=$(awk '$1 ~ /^DFF/ { s += $2 } END { print s + 0 }' "$log.stat")
    mems=$(grep -o '[0-9]\+' "$log.memories" | tail -1)
    slack=$(awk '/^worst slack/ { print $NF }' "$log.sta.log")
    total=$(awk '$1 == "Total" { print $5; exit }' "$log.sta.log")
    leak=$(awk '$1 == "Total" { print $4; exit }' "$log.sta.log")
    # The critical path's ends by the nets their flip-flops drive (cell
    # instance names are Yosys-generated; the Q nets keep the RTL's names).
    endname() {
      local inst
      inst=$(awk -v k="$1:" '$1 == k { print $2; exit }' "$log.sta.log")
      if [ -z "$inst" ]; then echo "?"; return; fi
      if ! grep -q " $inst (" "$log.netlist.v"; then echo "$inst"; return; fi
      awk -v i="$inst" '$2 == i && $3 == "(" { f = 1 } f && /\.Q\(/ { sub(/.*\.Q\(/, ""); sub(/\).*/, ""); gsub(/ /, ""); print; exit }' "$log.netlist.v"
    }
    from=$(endname Startpoint)
    to=$(endname Endpoint)
    [ -n "$area" ] && [ -n "$slack" ] && [ -n "$total" ] || { echo "asic.sh: could not read $log.stat / $log.sta.log" >&2; exit 1; }
    # Plausibility (Yosys can drop logic silently): six 32-bit comparators a
    # lane need well over 100 cells each; every memory stayed a $mem cell.
    expect_mems=$((6 * m + lanes))
    [ "$cells" -gt $((600 * lanes)) ] || { echo "asic.sh: $tag has only $cells cells for $lanes lanes" >&2; exit 1; }
    [ "$mems" -eq "$expect_mems" ] || { echo "asic.sh: $tag has $mems memories, expected $expect_mems" >&2; exit 1; }
    {
      echo "design = $d"
      echo "m = $m"
      echo "depth = $depth"
      echo "pair_rows = $pair_rows"
      echo "lanes = $lanes"
      echo "library = osu018_stdcells (0.18 um, 1.8 V, typical)"
      echo "rtl_sha256 = $rtl_sha"
      echo "logic_area_um2 = $area"
      echo "cells = $cells"
      echo "flip_flops = $ffs"
      echo "memories = $mems"
      echo "clock_period_ns = $period_ns"
      echo "worst_slack_ns = $slack"
      echo "critical_path_from = ${from:-?}"
      echo "critical_path_to = ${to:-?}"
      echo "power_total_w = $total"
      echo "power_leakage_w = $leak"
      echo "global_activity = $global_activity"
      echo "input_activity = $input_activity"
      echo "synthesis_seconds = $synth_s"
    } > "$out/$tag.txt"
    echo "$tag: $cells cells, $area um2, slack $slack ns at $period_ns ns, $total W"
  done
done
