// SPDX-License-Identifier: MIT
#include "gpu_report.hpp"

#include <fstream>

#include <nlohmann/json.hpp>

namespace hbp::cli {

std::optional<GpuReport> read_gpu_report(const std::string& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  try {
    nlohmann::json j;
    in >> j;
    if (j.value("dry_run", true)) return std::nullopt;
    GpuReport r;
    r.gpu = j.at("gpu").get<std::string>();
    r.date = j.value("date", "");
    r.host = j.value("host", "");
    if (r.host.rfind("host: ", 0) == 0) r.host.erase(0, 6);
    const nlohmann::json& p = j.at("paper_1024000");
    r.paper.frame_ms = p.at("frame_ms").get<double>();
    r.paper.with_transfers_ms = p.value("with_transfers_ms", 0.0);
    r.paper.energy_per_frame_j = p.value("energy_per_frame_j", 0.0);
    r.paper.axis_sweep_ms = p.value("axis_sweep_ms", 0.0);
    r.paper.lbvh_ms = p.value("lbvh_ms", 0.0);
    r.paper.cpu_sw_ms = p.value("cpu_sw_ms", 0.0);
    r.paper.cells_accelerator_ms = p.value("cpu_cells_gpu_accelerator_engine_ms", 0.0);
    // The curve: the runs of the frame's defaults, named "paper-N" by
    // scripts/gpu-check (its other paper runs at N objects try other
    // options: another sweep, cell shape, pair order or write).
    for (const nlohmann::json& run : j.value("runs", nlohmann::json::array())) {
      if (run.value("system", "") != "frame" || run.value("kind", "") != "paper" ||
          run.value("order", "").rfind("sorted", 0) != 0 || !run.value("exact", false))
        continue;
      const auto objects = static_cast<std::uint32_t>(run.at("objects").get<double>());
      if (run.value("name", "") != "paper-" + std::to_string(objects)) continue;
      r.paper_frame_ms[objects] = run.at("median_frame_ms").get<double>();
    }
    return r;
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  }
}

}  // namespace hbp::cli
