// SPDX-License-Identifier: MIT
// `hbp hw activity`: the switching activities the standard-cell flow hands to
// OpenSTA, measured with the C++ models on a paper-scene cell of 1024
// objects (the partition's cell limit) at m = 16: the share of lane-cycles
// that compare, times the toggle rate of the boxes' coordinate bits in
// buffer order; the load share for the inputs; the load/sequence shares and
// pair lines per cycle for the memory accesses.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cmd_hw_silicon.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp/hw/silicon_estimate.hpp"
#include "hbp/scenario.hpp"

namespace hbp::cli {
namespace {

struct ActivityOptions {
  std::uint32_t n = 1024;
  std::uint32_t m = 16;
  std::uint64_t seed = 1;
};

void run_activity(const ActivityOptions& o) {
  ScenarioParams sp;
  sp.n = o.n;
  sp.seed = o.seed;
  Scenario scenario(sp);
  BoxArray boxes;
  scenario.compute_boxes(boxes);
  const double toggles = hw::data_toggle_rate(boxes);
  std::printf("# Switching activities for rtl/synth/asic.sh, measured by: hbp hw activity --n %u --m %u --seed %llu\n",
              o.n, o.m, static_cast<unsigned long long>(o.seed));
  std::printf("# (C++ models on one paper-scene cell; toggles per clock; the clock net is OpenSTA's own)\n");
  std::printf("data_toggle_rate = %.6f\n", toggles);
  for (hw::Design d : {hw::Design::AreaEfficient, hw::Design::ManyObject}) {
    hw::ModelConfig cfg;
    cfg.m = o.m;
    cfg.depth = 1024;
    cfg.count_load = true;
    std::vector<Pair> pairs;
    hw::Counters k;
    std::uint32_t lanes = 0;
    if (d == hw::Design::AreaEfficient) {
      k = hw::AreaEfficientModel(cfg).run(boxes, pairs);
      lanes = 2 * o.m - 1;
    } else {
      k = hw::ManyObjectModel(cfg).run(boxes, pairs);
      lanes = o.m;
    }
    const hw::CycleActivity a = hw::cycle_activity(k, lanes, toggles);
    const char* p = d == hw::Design::AreaEfficient ? "ae" : "mo";
    std::printf("%s_cycles = %llu\n", p, static_cast<unsigned long long>(k.cycles.total()));
    std::printf("%s_global_activity = %.6f\n", p, a.datapath_activity);
    std::printf("%s_input_activity = %.6f\n", p, a.input_activity);
    std::printf("%s_load_fraction = %.6f\n", p, a.load_fraction);
    std::printf("%s_sequence_fraction = %.6f\n", p, a.sequence_fraction);
    std::printf("%s_pairs_per_cycle = %.6f\n", p, a.pairs_per_cycle);
  }
}

}  // namespace

void setup_hw_activity(CLI::App& hw) {
  auto o = std::make_shared<ActivityOptions>();
  CLI::App* a = hw.add_subcommand("activity",
                                  "Switching activities for the standard-cell flow, measured with the models on a paper-scene cell");
  a->add_option("--n", o->n, "Objects in the cell")->check(CLI::Range(2u, 1024u))->capture_default_str();
  a->add_option("--m", o->m, "Extensibility factor")->check(CLI::Range(1u, 64u))->capture_default_str();
  a->add_option("--seed", o->seed, "Scenario seed")->capture_default_str();
  a->callback([o] { run_activity(*o); });
}

}  // namespace hbp::cli
