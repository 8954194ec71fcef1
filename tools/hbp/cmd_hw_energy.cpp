// SPDX-License-Identifier: MIT
// `hbp hw energy`: energy per frame of the paper scene (default 1,024,000
// objects, cell limit 1024) on the modelled accelerator at each process node,
// against our CPU engine on this machine and the GPU engine's stored report.
//   ASIC: the models' cycles for the frame (the hybrid system's stats, plus
//         the cycles that load the cells' boxes) x energy per cycle (flow's
//         logic power at the measured activities + SRAM model); partition
//         excluded as in the paper, and with our CPU partition's energy added.
//   CPU:  the software engine's wall time (its own default cell limit) x
//         package power: RAPL (powercap)
//         where the machine exposes it, else an estimate labelled as such.
//   GPU:  read from the GPU check's report when one is stored; otherwise
//         "not yet measured".
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "cmd_hw_silicon.hpp"
#include "gpu_report.hpp"
#include "option_checks.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/model_config.hpp"
#include "hbp/hw/process_node.hpp"
#include "hbp/hw/silicon_estimate.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scenario.hpp"
#include "silicon_reports.hpp"

namespace hbp::cli {
namespace {

struct EnergyOptions {
  std::string reports = kDefaultAsicReports;
  std::string gpu_report = kGpuReportPath;
  std::uint32_t n = 1024000;
  std::uint32_t frames = 2;
  unsigned threads = 0;
  double cpu_watts_per_core = 4.4;
  bool json = false;
};

struct FrameRun {
  std::uint64_t cycles = 0;       // modelled, load excluded (the paper's)
  std::uint64_t load_cycles = 0;  // writing the cells' boxes into the buffer
  double wall_ms = 0, partition_ms = 0;
  std::optional<double> rapl_j;   // package energy of the frame, when measured
};

// Package energy counter (microjoules), when powercap exposes one.
std::optional<double> rapl_uj() {
  std::ifstream in("/sys/class/powercap/intel-rapl:0/energy_uj");
  double v = 0;
  if (in >> v) return v;
  return std::nullopt;
}

// The last of `frames` frames (the first builds the partition). cell_limit
// 0: the engine's own default.
FrameRun run_frames(const std::string& engine, std::uint32_t cell_limit, const EnergyOptions& o) {
  BroadPhaseOptions bo;
  bo.engine = engine;
  bo.cell_limit = cell_limit;
  bo.threads = o.threads;
  HybridBroadPhase hybrid(bo);
  ScenarioParams sp;
  sp.n = o.n;
  Scenario scenario(sp);
  BoxArray boxes;
  FrameRun r;
  for (std::uint32_t f = 0; f < o.frames; ++f) {
    scenario.compute_boxes(boxes);
    const std::optional<double> e0 = rapl_uj();
    hybrid.update(boxes);
    const std::optional<double> e1 = rapl_uj();
    const FrameStats& s = hybrid.stats();
    r.cycles = s.modelled_cycles;
    const double entries = s.duplication * static_cast<double>(o.n);
    r.load_cycles = static_cast<std::uint64_t>(std::ceil(entries / hw::ModelConfig{}.load_aabbs_per_cycle));
    r.wall_ms = s.wall_ms;
    r.partition_ms = s.partition_ms;
    r.rapl_j = e0 && e1 && *e1 >= *e0 ? std::optional<double>((*e1 - *e0) * 1e-6) : std::nullopt;
    scenario.step();
  }
  return r;
}

std::string cpu_estimate_label(const EnergyOptions& o) {
  char text[160];
  std::snprintf(text, sizeof text, "estimate: %.1f W per busy core x threads (no powercap on this machine)",
                o.cpu_watts_per_core);
  return text;
}

void run_energy(const EnergyOptions& o) {
  const SiliconReports s = read_silicon_reports(o.reports);
  const unsigned cores = o.threads != 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
  const FrameRun cpu = run_frames("sw", 0, o);
  const bool cpu_measured = cpu.rapl_j.has_value();
  const double cpu_watts = cores * o.cpu_watts_per_core;
  const double cpu_j = cpu_measured ? *cpu.rapl_j : cpu.wall_ms * 1e-3 * cpu_watts;
  const std::optional<GpuReport> report = read_gpu_report(o.gpu_report);
  const GpuReport* gpu = report && report->paper.energy_per_frame_j > 0 ? &*report : nullptr;
  // The stored GPU frame is the paper scene at 1,024,000 objects: a ratio to
  // another scene size would compare different work.
  const bool gpu_comparable = gpu && o.n == 1024000;

  nlohmann::json j;
  j["scene"] = {{"kind", "paper"}, {"n", o.n}, {"cell_limit", 1024}, {"frames", o.frames}};
  j["cpu"] = {{"engine", "sw (its default cell limit)"},
              {"threads", cores},
              {"frame_ms", cpu.wall_ms},
              {"energy_per_frame_j", cpu_j},
              {"measured", cpu_measured},
              {"power_source", cpu_measured ? std::string("RAPL package energy (powercap)") : cpu_estimate_label(o)}};
  j["gpu"] = gpu ? nlohmann::json{{"gpu", gpu->gpu}, {"energy_per_frame_j", gpu->paper.energy_per_frame_j},
                                  {"frame_ms", gpu->paper.frame_ms}, {"date", gpu->date}, {"measured", true},
                                  {"report", o.gpu_report}}
                 : nlohmann::json{{"measured", false}, {"note", "not yet measured (no GPU report at " + o.gpu_report + ")"}};
  j["asic"] = nlohmann::json::array();

  if (!o.json) {
    std::printf("Energy per frame, paper scene, n = %u, cell limit 1024 (last of %u frames)\n\n", o.n, o.frames);
  }
  for (hw::Design d : {hw::Design::AreaEfficient, hw::Design::ManyObject}) {
    const hw::AsicReport* r16 = nullptr;
    for (const hw::AsicReport& r : s.reports)
      if (r.design == d && r.m == 16) r16 = &r;
    if (!r16) throw InvalidInput("no m = 16 report for " + std::string(hw::design_name(d)) + " in " + o.reports);
    const FrameRun acc = run_frames(d == hw::Design::AreaEfficient ? "ae" : "mo", 1024, o);
    const hw::CycleActivity a = s.cycle_activity(d);
    const std::uint64_t cycles = acc.cycles + acc.load_cycles;
    const double partition_j = acc.partition_ms * 1e-3 * cpu_watts;
    for (const hw::ProcessNode& n : hw::process_nodes()) {
      const hw::EnergyPerCycle e = hw::energy_per_cycle(*r16, a, n);
      const double frame_j = static_cast<double>(cycles) * e.total_j();
      j["asic"].push_back({{"design", hw::design_name(d)},
                           {"node", n.name},
                           {"modelled", true},
                           {"cycles", acc.cycles},
                           {"load_cycles", acc.load_cycles},
                           {"frame_ms_at_500mhz", static_cast<double>(cycles) / hw::ModelConfig{}.clock_hz * 1e3},
                           {"energy_per_cycle_pj", e.total_j() * 1e12},
                           {"memory_share", e.memory_share()},
                           {"energy_per_frame_j", frame_j},
                           {"partition_ms", acc.partition_ms},
                           {"energy_per_frame_with_partition_j", frame_j + partition_j},
                           {"cpu_over_asic", cpu_j / frame_j},
                           {"cpu_over_asic_with_partition", cpu_j / (frame_j + partition_j)},
                           {"gpu_over_asic", gpu_comparable ? nlohmann::json(gpu->paper.energy_per_frame_j / frame_j) : nlohmann::json(nullptr)}});
    }
  }
  if (o.json) {
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("%-15s %-6s %12s %11s %10s %7s %13s %15s %10s %10s\n", "ASIC (model)", "node", "cycles+load",
              "ms@500MHz", "pJ/cycle", "mem%", "J/frame", "J/frame+part.", "CPU/ASIC", "(+part.)");
  for (const nlohmann::json& a : j["asic"]) {
    std::printf("%-15s %-6s %12llu %11.3f %10.1f %6.1f%% %13.4g %15.4g %10.0f %10.2f\n",
                a["design"].get<std::string>().c_str(), a["node"].get<std::string>().c_str(),
                static_cast<unsigned long long>(a["cycles"].get<std::uint64_t>() + a["load_cycles"].get<std::uint64_t>()),
                a["frame_ms_at_500mhz"].get<double>(), a["energy_per_cycle_pj"].get<double>(),
                100 * a["memory_share"].get<double>(), a["energy_per_frame_j"].get<double>(),
                a["energy_per_frame_with_partition_j"].get<double>(), a["cpu_over_asic"].get<double>(),
                a["cpu_over_asic_with_partition"].get<double>());
  }
  std::printf("\nCPU (sw engine, %u threads, this machine): %.2f ms/frame, %.4g J/frame (%s)\n", cores, cpu.wall_ms,
              cpu_j, j["cpu"]["power_source"].get<std::string>().c_str());
  if (gpu) {
    std::printf("GPU (%s, measured %s, %s): %.3f ms/frame, %.4g J/frame\n", gpu->gpu.c_str(), gpu->date.c_str(),
                o.gpu_report.c_str(), gpu->paper.frame_ms, gpu->paper.energy_per_frame_j);
    if (gpu_comparable) {
      std::printf("GPU/ASIC (energy per frame, partition excluded on the ASIC):");
      for (const nlohmann::json& a : j["asic"])
        std::printf(" %s %s %.0fx;", a["design"].get<std::string>().c_str(), a["node"].get<std::string>().c_str(),
                    a["gpu_over_asic"].get<double>());
      std::printf("\n");
    } else {
      std::printf("GPU/ASIC: the GPU's frame is the paper scene at 1,024,000 objects; no ratio at n = %u\n", o.n);
    }
  } else
    std::printf("GPU: not yet measured (no GPU report at %s)\n", o.gpu_report.c_str());
}

}  // namespace

void setup_hw_energy(CLI::App& hw) {
  auto o = std::make_shared<EnergyOptions>();
  CLI::App* e = hw.add_subcommand("energy", "Energy per frame of the paper scene: modelled ASIC vs our CPU engine vs the GPU report");
  e->add_option("--reports", o->reports, "Folder of rtl/synth/asic.sh's reports")->capture_default_str();
  e->add_option("--gpu-report", o->gpu_report, "The GPU check's JSON report")->capture_default_str();
  e->add_option("-n,--n", o->n, "Objects")->check(CLI::Range(2u, 16000000u))->capture_default_str();
  e->add_option("--frames", o->frames, "Frames per system (the last is reported)")->check(CLI::Range(1u, 100u))->capture_default_str();
  e->add_option("--threads", o->threads, "CPU threads (0: all cores)")->check(threads_range())->capture_default_str();
  e->add_option("--cpu-watts-per-core", o->cpu_watts_per_core,
                "CPU power estimate per busy core when powercap has no package energy")
      ->check(positive_finite())
      ->capture_default_str();
  e->add_flag("--json", o->json, "JSON output");
  e->callback([o] { run_energy(*o); });
}

}  // namespace hbp::cli
