// SPDX-License-Identifier: MIT
// The silicon estimates: the SRAM model and node scaling against hand
// arithmetic, and the standard-cell flow's stored reports (docs/results/asic)
// against the models: every configuration present, the memories the flow
// left unsynthesised exactly the SRAM model's inventory, and the measured
// activities' cycle counts equal to the models' analytic cycles.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "hbp/box_array.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/asic_report.hpp"
#include "hbp/hw/process_node.hpp"
#include "hbp/hw/silicon_estimate.hpp"
#include "hbp/hw/sram_model.hpp"

namespace hbp::hw {
namespace {

const std::filesystem::path kReports = std::filesystem::path(HBP_SOURCE_DIR) / "docs/results/asic";

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

double activity(const std::string& key) {
  std::istringstream in(read_text(kReports / "activities.txt"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key + " = ", 0) == 0) return std::stod(line.substr(key.size() + 3));
  }
  ADD_FAILURE() << "activities.txt has no " << key;
  return -1;
}

TEST(SramModel, AreaIsBitsTimesCellTimesPortFactorOverEfficiency) {
  const SramMacro buffer{1024, 32, true};
  // 32768 bits x 5.59 um2 x 2 (dual port) / 0.7
  EXPECT_NEAR(sram_area_um2(buffer, synthesis_node()), 523351.8, 0.1);
  const SramMacro single{1024, 32, false};
  EXPECT_NEAR(sram_area_um2(single, synthesis_node()), 261675.9, 0.1);
}

TEST(SramModel, AccessEnergyByHand) {
  // 180 nm, 1.8 V: bit lines 32 x 1024 x 2 fF x 1.8 x 0.18 = 21.23 pJ,
  // word line 32 x 2 fF x 3.24 = 0.207 pJ, periphery 32 x 10 fF x 3.24 = 1.037 pJ.
  EXPECT_NEAR(sram_access_energy_j({1024, 32, true}, synthesis_node()) * 1e12, 22.48, 0.01);
  // Lower supply and smaller cells: much less at 28 nm.
  EXPECT_LT(sram_access_energy_j({1024, 32, true}, find_process_node("28nm")),
            0.05 * sram_access_energy_j({1024, 32, true}, synthesis_node()));
}

TEST(ProcessNode, ScaleFactors) {
  EXPECT_DOUBLE_EQ(area_scale(synthesis_node()), 1.0);
  EXPECT_DOUBLE_EQ(energy_scale(synthesis_node()), 1.0);
  EXPECT_NEAR(area_scale(find_process_node("28nm")), 0.127 / 5.59, 1e-12);
  // sqrt(0.127 / 5.59) x (1.0 / 1.8)^2
  EXPECT_NEAR(energy_scale(find_process_node("28nm")), 0.046521, 1e-5);
  EXPECT_THROW(find_process_node("7nm"), InvalidInput);
}

TEST(SiliconEstimate, MemoryInventoryFollowsTheRtl) {
  const MemoryInventory ae = memory_inventory(Design::AreaEfficient, 16, 1024, 512);
  EXPECT_EQ(ae.buffer_count, 96u);
  EXPECT_EQ(ae.pair_banks, 31u);
  EXPECT_EQ(ae.pair_bank.bits, 20u);  // two 10-bit indices (capacity 1024)
  const MemoryInventory mo = memory_inventory(Design::ManyObject, 16, 1024, 512);
  EXPECT_EQ(mo.buffer_count, 96u);
  EXPECT_EQ(mo.pair_banks, 16u);
  EXPECT_EQ(mo.pair_bank.bits, 28u);  // two 14-bit indices (capacity 16,384)
}

TEST(SiliconEstimate, DataToggleRate) {
  BoxArray boxes;
  boxes.push_back(Aabb{{0, 0, 0}, {0, 0, 0}});
  boxes.push_back(Aabb{{0, 0, 0}, {0, 0, 0}});
  EXPECT_DOUBLE_EQ(data_toggle_rate(boxes), 0.0);
  BoxArray two;
  const float a = std::bit_cast<float>(0x00000000u), b = std::bit_cast<float>(0x7F7FFFFFu);  // 0, FLT_MAX
  two.push_back(Aabb{{a, a, a}, {a, a, a}});
  two.push_back(Aabb{{b, b, b}, {b, b, b}});
  EXPECT_DOUBLE_EQ(data_toggle_rate(two), 30.0 / 32.0);  // 0x7F7FFFFF: 30 bits set
  two.push_back(Aabb{{a, a, a}, {a, a, a}});
  EXPECT_DOUBLE_EQ(data_toggle_rate(two), 30.0 / 32.0);  // and back
}

TEST(AsicReport, MalformedReportNamesTheKey) {
  try {
    parse_asic_report("design = ae\nm = 2\n", "x.txt");
    FAIL() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("x.txt"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("depth"), std::string::npos);
  }
  EXPECT_THROW(parse_asic_report("design = ae\nm = two\n", "y.txt"), InvalidInput);
}

TEST(AsicReports, EveryConfigurationStoredAndConsistentWithTheModels) {
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    double previous_area = 0;
    for (std::uint32_t m : {1u, 2u, 4u, 8u, 16u}) {
      const std::string name = std::string(d == Design::AreaEfficient ? "ae" : "mo") + "_m" + std::to_string(m) + ".txt";
      SCOPED_TRACE(name);
      const AsicReport r = parse_asic_report(read_text(kReports / name), name);
      EXPECT_EQ(r.design, d);
      EXPECT_EQ(r.m, m);
      EXPECT_EQ(r.depth, 1024u);
      EXPECT_EQ(r.lanes, d == Design::AreaEfficient ? 2 * m - 1 : m);
      // The flow left exactly the SRAM model's memories unsynthesised.
      EXPECT_EQ(r.memories, memory_inventory(d, m, r.depth, r.pair_rows).count());
      // Logic grows with the lanes; a 180 nm design of this size closes
      // timing somewhere between 50 and 500 MHz.
      EXPECT_GT(r.logic_area_um2, previous_area);
      previous_area = r.logic_area_um2;
      EXPECT_GT(r.fmax_hz(), 50e6);
      EXPECT_LT(r.fmax_hz(), 500e6);
      EXPECT_NEAR(r.logic_energy_per_cycle_j(), r.power_total_w * r.clock_period_ns * 1e-9, 1e-18);
      // The activities the report was made with are the measured ones.
      const std::string p = d == Design::AreaEfficient ? "ae_" : "mo_";
      EXPECT_DOUBLE_EQ(r.global_activity, activity(p + "global_activity"));
      EXPECT_DOUBLE_EQ(r.input_activity, activity(p + "input_activity"));
    }
  }
}

TEST(AsicReports, MeasuredActivitiesMatchTheModelsCycles) {
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    ModelConfig cfg;
    cfg.m = 16;
    cfg.depth = 1024;
    cfg.count_load = true;
    const CycleBreakdown c = analytic_cycles(d, 1024, cfg);
    const std::string p = d == Design::AreaEfficient ? "ae_" : "mo_";
    EXPECT_EQ(static_cast<std::uint64_t>(activity(p + "cycles")), c.total());
    EXPECT_NEAR(activity(p + "load_fraction"), static_cast<double>(c.load) / c.total(), 1e-6);
    EXPECT_NEAR(activity(p + "sequence_fraction"), static_cast<double>(c.sequence) / c.total(), 1e-6);
    const double toggles = activity("data_toggle_rate");
    EXPECT_GT(toggles, 0.05);
    EXPECT_LT(toggles, 0.6);
    EXPECT_NEAR(activity(p + "input_activity"), activity(p + "load_fraction") * toggles, 1e-5);
  }
}

}  // namespace
}  // namespace hbp::hw
