// SPDX-License-Identifier: MIT
// The cell engine registry: the core's own engines, the hardware models'
// registration (hbp::hw::register_cell_engines, called by this suite's main
// and idempotent), and names taken once.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "hbp/cell_engine.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#include "hbp/software_engine.hpp"

namespace {

std::unique_ptr<hbp::CellEngine> make_other_sweep() {
  return std::make_unique<hbp::SoftwareEngine>(hbp::SoftwareEngine::Kernel::Sweep);
}
std::unique_ptr<hbp::CellEngine> make_other_brute() { return std::make_unique<hbp::BruteForceEngine>(); }

// The message of the InvalidInput that f throws ("" when it throws none).
template <class F>
std::string invalid_input_message(F&& f) {
  try {
    f();
  } catch (const hbp::InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(EngineRegistry, HoldsTheCoreAndTheHardwareEnginesSorted) {
  hbp::hw::register_cell_engines();  // again: idempotent
  const std::vector<std::string> names = hbp::cell_engine_names();
  for (const char* n : {"sw", "sw-allpairs", "brute", "ae", "mo", "ae-sim", "mo-sim"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
    EXPECT_EQ(hbp::make_cell_engine(n)->name(), n);
  }
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  EXPECT_EQ(std::adjacent_find(names.begin(), names.end()), names.end());
}

TEST(EngineRegistry, DescriptionsSayWhatAeAndMoRun) {
  for (const char* n : {"ae", "mo"}) {
    const std::string d = hbp::cell_engine_description(n);
    EXPECT_NE(d.find("analytic cycles"), std::string::npos) << n << ": " << d;
    EXPECT_NE(d.find("software"), std::string::npos) << n << ": " << d;
  }
  for (const char* n : {"ae-sim", "mo-sim"})
    EXPECT_NE(hbp::cell_engine_description(n).find("simulated"), std::string::npos) << n;
  EXPECT_NE(invalid_input_message([] { hbp::cell_engine_description("nope"); }).find("'nope'"), std::string::npos);
}

TEST(EngineRegistry, ATakenNameIsAnErrorNamingIt) {
  // A built-in name.
  std::string m = invalid_input_message([] { hbp::register_cell_engine("sw", &make_other_sweep); });
  EXPECT_NE(m.find("'sw'"), std::string::npos) << m;
  EXPECT_NE(m.find("built-in"), std::string::npos) << m;
  // A name the hardware models registered, with another factory.
  m = invalid_input_message([] { hbp::register_cell_engine("ae", &make_other_sweep); });
  EXPECT_NE(m.find("'ae'"), std::string::npos) << m;
  EXPECT_NE(m.find("already taken"), std::string::npos) << m;
  // Registered here: the same factory again is a no-op, another one an error.
  hbp::register_cell_engine("registry-test-brute", &make_other_brute);
  hbp::register_cell_engine("registry-test-brute", &make_other_brute);
  m = invalid_input_message([] { hbp::register_cell_engine("registry-test-brute", &make_other_sweep); });
  EXPECT_NE(m.find("'registry-test-brute'"), std::string::npos) << m;
  // Nothing was replaced.
  EXPECT_EQ(hbp::make_cell_engine("sw")->name(), hbp::SoftwareEngine(hbp::SoftwareEngine::Kernel::Sweep).name());
  EXPECT_EQ(hbp::make_cell_engine("ae")->name(), "ae");
  EXPECT_EQ(hbp::make_cell_engine("registry-test-brute")->name(), hbp::BruteForceEngine().name());
}

TEST(EngineRegistry, UnknownNameListsTheKnownOnes) {
  const std::string m = invalid_input_message([] { hbp::make_cell_engine("nope"); });
  EXPECT_NE(m.find("unknown engine 'nope'"), std::string::npos) << m;
  EXPECT_NE(m.find("ae, ae-sim, brute"), std::string::npos) << m;
}

}  // namespace
