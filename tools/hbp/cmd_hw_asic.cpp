// SPDX-License-Identifier: MIT
// `hbp hw asic`: area, cells, fmax and power of both microarchitectures in
// the OSU 0.18 um standard-cell library (rtl/synth/asic.sh's stored reports),
// the memories from the analytic SRAM model, and the totals scaled to 28 nm
// and 5 nm; the share of a GTX TITAN X die beside the paper's estimate.
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "cmd_hw_silicon.hpp"
#include "hbp/hw/process_node.hpp"
#include "hbp/hw/silicon_estimate.hpp"
#include "silicon_reports.hpp"

namespace hbp::cli {
namespace {

// Paper, section 5: share of the TITAN X die, from FPGA figures.
constexpr double kPaperDiePercentAe = 0.072;
constexpr double kPaperDiePercentMo = 0.086;

struct AsicOptions {
  std::string reports = kDefaultAsicReports;
  bool json = false;
};

double die_percent(const hw::AsicReport& r) {
  return hw::silicon_area(r, hw::find_process_node("28nm")).total_um2() / (hw::kTitanXDieMm2 * 1e6) * 100.0;
}

nlohmann::json row_json(const hw::AsicReport& r) {
  const hw::MemoryInventory inv = hw::memory_inventory(r.design, r.m, r.depth, r.pair_rows);
  nlohmann::json j = {{"design", hw::design_name(r.design)},
                      {"m", r.m},
                      {"depth", r.depth},
                      {"lanes", r.lanes},
                      {"cells", r.cells},
                      {"flip_flops", r.flip_flops},
                      {"memories", inv.count()},
                      {"critical_path_ns", r.critical_path_ns()},
                      {"critical_path", {{"from", r.critical_path_from}, {"to", r.critical_path_to}}},
                      {"fmax_mhz", r.fmax_hz() / 1e6},
                      {"power_w_at_100mhz", r.power_total_w},
                      {"logic_energy_per_cycle_pj", r.logic_energy_per_cycle_j() * 1e12},
                      {"die_percent_titan_x", die_percent(r)}};
  for (const hw::ProcessNode& n : hw::process_nodes()) {
    const hw::SiliconArea a = hw::silicon_area(r, n);
    j["area"][n.name] = {{"logic_um2", a.logic_um2}, {"memory_um2", a.memory_um2}, {"total_um2", a.total_um2()},
                         {"memory_share", a.memory_share()},
                         {"logic_source", &n == &hw::synthesis_node() ? "synthesised" : "scaled from the synthesised node"},
                         {"memory_source", "analytic SRAM model"}};
  }
  return j;
}

void run_asic(const AsicOptions& o) {
  const SiliconReports s = read_silicon_reports(o.reports);
  if (o.json) {
    nlohmann::json j;
    j["library"] = "osu018_stdcells (0.18 um, 1.8 V, typical); logic measured by the flow, memories modelled";
    j["reports"] = o.reports;
    j["rows"] = nlohmann::json::array();
    for (const hw::AsicReport& r : s.reports) j["rows"].push_back(row_json(r));
    j["paper_die_percent"] = {{"area-efficient", kPaperDiePercentAe}, {"many-object", kPaperDiePercentMo}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("Standard cells: OSU 0.18 um (osu018_stdcells, 1.8 V, typical), Yosys + ABC, OpenSTA\n");
  std::printf("logic: synthesised (flow reports in %s); memories: analytic SRAM model; 28/5 nm: scaled\n\n", o.reports.c_str());
  std::printf("%-15s %3s %5s %7s %6s %11s %4s %11s %6s %6s %8s %8s %9s %9s\n", "design", "m", "depth", "cells", "FFs",
              "logic um2", "mem", "memory um2", "mem%", "fmax", "mW@100M", "pJ/cyc", "28nm mm2", "5nm mm2");
  const hw::ProcessNode& n180 = hw::synthesis_node();
  for (const hw::AsicReport& r : s.reports) {
    const hw::SiliconArea a = hw::silicon_area(r, n180);
    std::printf("%-15s %3u %5u %7llu %6llu %11.0f %4u %11.0f %5.1f%% %6.1f %8.2f %8.1f %9.4f %9.5f\n",
                hw::design_name(r.design), r.m, r.depth, static_cast<unsigned long long>(r.cells),
                static_cast<unsigned long long>(r.flip_flops), a.logic_um2,
                hw::memory_inventory(r.design, r.m, r.depth, r.pair_rows).count(), a.memory_um2,
                100 * a.memory_share(), r.fmax_hz() / 1e6, r.power_total_w * 1e3, r.logic_energy_per_cycle_j() * 1e12,
                hw::silicon_area(r, hw::find_process_node("28nm")).total_um2() / 1e6,
                hw::silicon_area(r, hw::find_process_node("5nm")).total_um2() / 1e6);
  }
  std::printf("\nCritical paths (register nets at their ends):\n");
  for (const hw::AsicReport& r : s.reports)
    std::printf("  %-15s m = %2u: %.2f ns, %s -> %s\n", hw::design_name(r.design), r.m, r.critical_path_ns(),
                r.critical_path_from.c_str(), r.critical_path_to.c_str());
  std::printf("\nShare of a GTX TITAN X die (GM200, TSMC 28 nm, %.0f mm2), m = 16, depth 1024:\n", hw::kTitanXDieMm2);
  for (const hw::AsicReport& r : s.reports) {
    if (r.m != 16) continue;
    const bool ae = r.design == hw::Design::AreaEfficient;
    std::printf("  %-15s capacity %5u: ours %.4f %% (logic + SRAM scaled to 28 nm), paper %.3f %% (from FPGA figures)\n",
                hw::design_name(r.design), ae ? r.depth : r.depth * r.m, die_percent(r),
                ae ? kPaperDiePercentAe : kPaperDiePercentMo);
  }
}

}  // namespace

void setup_hw_asic(CLI::App& hw) {
  auto o = std::make_shared<AsicOptions>();
  CLI::App* a = hw.add_subcommand("asic", "Area, cells, fmax and power in a standard-cell library (the flow's stored reports), scaled to 28 and 5 nm");
  a->add_option("--reports", o->reports, "Folder of rtl/synth/asic.sh's reports")->capture_default_str();
  a->add_flag("--json", o->json, "JSON output");
  a->callback([o] { run_asic(*o); });
}

}  // namespace hbp::cli
