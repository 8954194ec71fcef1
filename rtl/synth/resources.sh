#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Synthesis resource table of both microarchitectures with Yosys.
#
#   rtl/synth/resources.sh [--designs "ae mo"] [--m "1 2 4 8 16"] [--depth 1024]
#                          [--ice40] [--pnr] [--generic]
#
# Default: Xilinx 7-series (synth_xilinx -family xc7, true-dual-port
# RAMB18E1/RAMB36E1) for m = 1 2 4 8 16, memory depth 1024, pair memory of
# 512 rows per lane. Prints one line per configuration: LUTs, flip-flops,
# block RAMs (in RAMB36 equivalents and as counted), DSPs, carry cells, and
# checks that the netlist is plausible (non-zero logic, memories mapped to
# block RAM, none left as flip-flops): Yosys 0.23 can silently drop logic.
#   --ice40    also synth_ice40 for m = 1 and 2 (depth 256, SB_RAM40_4K)
#   --pnr      also nextpnr-ice40 (up5k) on area-efficient m = 1, depth 256:
#              max frequency estimate (needs nextpnr-ice40, fpga-icestorm)
#   --generic  also plain `synth` (technology independent) for m = 1, depth 64
# Slow (minutes per m = 16 run): not part of CI. Logs in rtl/synth/out/.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
rtl="$(dirname "$here")"
out="$here/out"
mkdir -p "$out"

designs="ae mo"
ms="1 2 4 8 16"
depth=1024
pair_rows=512
ice40=0 pnr=0 generic=0
while [ $# -gt 0 ]; do
  case "$1" in
    --designs) designs="$2"; shift 2 ;;
    --m) ms="$2"; shift 2 ;;
    --depth) depth="$2"; shift 2 ;;
    --ice40) ice40=1; shift ;;
    --pnr) pnr=1; shift ;;
    --generic) generic=1; shift ;;
    *) echo "resources.sh: unknown option $1" >&2; exit 2 ;;
  esac
done

common="$rtl/hbp_fcmp_le.sv $rtl/hbp_box_overlap.sv $rtl/hbp_dpram.sv $rtl/hbp_delay.sv $rtl/hbp_pair_memory.sv $rtl/hbp_run_control.sv"
sources() {
  if [ "$1" = ae ]; then echo "$rtl/area_efficient.sv $rtl/hbp_ae_sequencer.sv $common";
  else echo "$rtl/many_object.sv $rtl/hbp_mo_sequencer.sv $common"; fi
}
top() { if [ "$1" = ae ]; then echo hbp_area_efficient; else echo hbp_many_object; fi; }

# count CELLTYPE... from a Yosys stat file (sum over the given cell types)
count() {
  local f="$1"; shift
  local total=0 v
  for c in "$@"; do
    v=$(awk -v c="$c" '$1 == c { s += $2 } END { print s + 0 }' "$f")
    total=$((total + v))
  done
  echo "$total"
}

fail=0
check() {  # name cond message
  if ! eval "$2"; then echo "  CHECK FAILED ($1): $3" >&2; fail=1; fi
}

run_yosys() {  # design m depth flow -> stat file
  local d="$1" m="$2" dp="$3" flow="$4"
  local tag="${d}_m${m}_d${dp}_${flow}"
  local script="$out/$tag.ys"
  {
    echo "read_verilog -sv $(sources "$d")"
    echo "hierarchy -top $(top "$d") -chparam M $m -chparam DEPTH $dp -chparam PAIR_ROWS $pair_rows"
    case "$flow" in
      xc7) echo "synth_xilinx -family xc7 -top $(top "$d") -flatten" ;;
      ice40) echo "synth_ice40 -top $(top "$d") -json $out/$tag.json" ;;
      generic) echo "synth -top $(top "$d") -flatten" ;;
    esac
    echo "tee -o $out/$tag.stat stat"
  } > "$script"
  local t0=$SECONDS
  yosys -q -l "$out/$tag.log" -s "$script" > /dev/null 2>&1 || { echo "yosys failed: $out/$tag.log" >&2; fail=1; }
  echo $((SECONDS - t0)) > "$out/$tag.seconds"
  echo "$out/$tag.stat"
}

printf '%-15s %3s %6s %8s %8s %10s %10s %5s %7s %6s\n' design m depth LUTs FFs "RAMB36eq" "RAMB36/18" DSPs CARRY4 secs
for d in $designs; do
  for m in $ms; do
    s=$(run_yosys "$d" "$m" "$depth" xc7)
    luts=$(count "$s" LUT1 LUT2 LUT3 LUT4 LUT5 LUT6)
    ffs=$(count "$s" FDRE FDSE FDCE FDPE)
    r36=$(count "$s" RAMB36E1)
    r18=$(count "$s" RAMB18E1)
    dsp=$(count "$s" DSP48E1)
    carry=$(count "$s" CARRY4)
    lutram=$(count "$s" RAM32M RAM64M RAM32X1D RAM64X1D RAM128X1D RAM256X1S)
    secs=$(cat "${s%.stat}.seconds")
    name=$([ "$d" = ae ] && echo area-efficient || echo many-object)
    eq=$(awk -v a="$r36" -v b="$r18" 'BEGIN { printf "%.1f", a + b / 2 }')
    printf '%-15s %3d %6d %8d %8d %10s %10s %5d %7d %6d\n' "$name" "$m" "$depth" "$luts" "$ffs" "$eq" "$r36/$r18" "$dsp" "$carry" "$secs"
    # Plausibility: comparators exist (carry chains, LUTs), the 6m buffer
    # memories (1024 x 32 bits = one RAMB36 each) and the pair memory lanes
    # became block RAM, no memory was left in flip-flops or LUT RAM.
    lanes=$([ "$d" = ae ] && echo $((2 * m - 1)) || echo "$m")
    check "$name m=$m" "[ $luts -gt $((100 * lanes)) ]" "only $luts LUTs for $lanes compare lanes"
    check "$name m=$m" "[ $carry -ge $((6 * lanes * 4)) ]" "only $carry CARRY4 for $((6 * lanes)) comparators"
    check "$name m=$m" "awk 'BEGIN{exit !($eq >= 6 * $m)}'" "$eq RAMB36 equivalents < 6m = $((6 * m)) buffer memories"
    check "$name m=$m" "[ $lutram -eq 0 ]" "$lutram LUT-RAM cells: a memory was not mapped to block RAM"
    check "$name m=$m" "[ $ffs -lt $((lanes * 2000 + 20000)) ]" "$ffs flip-flops: a memory was mapped to registers?"
  done
done

if [ "$ice40" = 1 ]; then
  echo
  printf '%-15s %3s %6s %8s %8s %10s %7s\n' design m depth LUT4 FFs SB_RAM40 SB_CARRY
  for d in $designs; do
    for m in 1 2; do
      s=$(run_yosys "$d" "$m" 256 ice40)
      luts=$(count "$s" SB_LUT4)
      ffs=$(count "$s" SB_DFF SB_DFFE SB_DFFSR SB_DFFESR SB_DFFR SB_DFFER SB_DFFS SB_DFFES)
      ram=$(count "$s" SB_RAM40_4K)
      carry=$(count "$s" SB_CARRY)
      name=$([ "$d" = ae ] && echo area-efficient || echo many-object)
      printf '%-15s %3d %6d %8d %8d %10d %7d\n' "$name" "$m" 256 "$luts" "$ffs" "$ram" "$carry"
      check "$name ice40 m=$m" "[ $ram -gt 0 ] && [ $luts -gt 200 ]" "implausible ice40 netlist"
    done
  done
fi

if [ "$pnr" = 1 ]; then
  echo
  if command -v nextpnr-ice40 > /dev/null; then
    # The core behind a few pins (synth/pnr_wrap.sv), area-efficient m = 1.
    j="$out/pnr_ae_m1_d256.json"
    yosys -q -l "$out/pnr_ae_m1_d256.log" -p "read_verilog -sv $(sources ae) $here/pnr_wrap.sv; \
      hierarchy -top hbp_pnr_wrap -chparam M 1 -chparam DEPTH 256; \
      synth_ice40 -top hbp_pnr_wrap -json $j; tee -o $out/pnr_ae_m1_d256.stat stat" > /dev/null 2>&1 \
      || { echo "yosys failed: $out/pnr_ae_m1_d256.log" >&2; fail=1; }
    for dev in up5k hx8k; do
      pkg=$([ "$dev" = up5k ] && echo sg48 || echo ct256)
      if timeout 1800 nextpnr-ice40 --"$dev" --package "$pkg" --json "$j" --freq 50 \
           --timing-allow-fail --log "$out/pnr_ae_m1_$dev.log" > /dev/null 2>&1; then
        f=$(grep -o "Max frequency for clock[^:]*: [0-9.]* MHz" "$out/pnr_ae_m1_$dev.log" | tail -1 | sed 's/.*: //')
        u=$(grep -E "ICESTORM_LC:|ICESTORM_RAM:" "$out/pnr_ae_m1_$dev.log" | head -2 | tr -s ' ' | tr '\n' ' ')
        echo "nextpnr-ice40 $dev: area-efficient m=1 depth 256 placed and routed, Fmax $f; $u"
      else
        echo "nextpnr-ice40 $dev: area-efficient m=1 depth 256 did not place/route (see $out/pnr_ae_m1_$dev.log)"
      fi
    done
  else
    echo "nextpnr-ice40 not installed: apt-get install nextpnr-ice40 fpga-icestorm"
  fi
fi

if [ "$generic" = 1 ]; then
  echo
  for d in $designs; do
    s=$(run_yosys "$d" 1 64 generic)
    cells=$(awk '/Number of cells:/ { n = $4 } END { print n + 0 }' "$s")
    echo "generic synth $(top "$d") m=1 depth 64: $cells cells (memories become flip-flops: $(count "$s" '$_DFF_P_' '$_DFFE_PP_' '$_SDFF_PP0_' '$_SDFFE_PP0P_' '$_DFFE_PN0P_') DFF cells)"
    check "generic $d" "[ $cells -gt 1000 ]" "implausible generic netlist"
  done
fi

exit $fail
