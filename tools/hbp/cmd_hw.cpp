// SPDX-License-Identifier: MIT
// `hbp hw ...`: the cycle-accurate microarchitecture models from the command
// line.
//   table    modelled time next to the paper's Table 4 (optionally with the
//            partitioned columns, run through the hybrid system)
//   explore  cycles, time, utilisation, capacity and resources over a grid
//            of n and m, for design-space exploration
//   trace    the per-cycle sequence in the layout of Tables 1 and 3
//   run      one scene through a simulated model: counters and oracle check
//   activity, asic, energy: the silicon estimates (cmd_hw_silicon.hpp)
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cmd_hw_silicon.hpp"
#include "command_registry.hpp"
#include "option_checks.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp/benchdata/paper_table4.hpp"
#include "hbp/benchdata/paper_tables.hpp"
#include "hbp/hw/resources.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scenario.hpp"

namespace hbp::cli {
namespace {

using hbp::hw::Design;
using hbp::hw::ModelConfig;

// ---------------------------------------------------------------- ranges

std::uint64_t parse_count(const std::string& text, const std::string& option) {
  std::uint64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, v);
  if (ec != std::errc() || p != end) {
    throw InvalidInput(option + ": '" + text + "' is not a non-negative integer");
  }
  return v;
}

// "a..b" doubles from a and ends with b; "a..b:+s" steps by s; "a..b:*f"
// multiplies by f; "x,y,z" lists values. Ranges and lists may be mixed:
// "1..4:+1,16,32".
std::vector<std::uint64_t> parse_range(const std::string& text, const std::string& option) {
  std::vector<std::uint64_t> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const std::size_t dots = item.find("..");
    if (dots == std::string::npos) {
      out.push_back(parse_count(item, option));
    } else {
      const std::size_t colon = item.find(':', dots);
      const std::uint64_t first = parse_count(item.substr(0, dots), option);
      const std::uint64_t last =
          parse_count(item.substr(dots + 2, colon == std::string::npos ? std::string::npos : colon - dots - 2), option);
      char how = '*';
      std::uint64_t by = 2;
      if (colon != std::string::npos) {
        const std::string rule = item.substr(colon + 1);
        if (rule.size() < 2 || (rule[0] != '+' && rule[0] != '*')) {
          throw InvalidInput(option + ": step '" + rule + "' in '" + item + "' must be +s or *f");
        }
        how = rule[0];
        by = parse_count(rule.substr(1), option);
      }
      if (first > last) throw InvalidInput(option + ": '" + item + "' runs backwards");
      if ((how == '+' && by == 0) || (how == '*' && (by < 2 || first == 0))) {
        throw InvalidInput(option + ": '" + item + "' never advances (use a start >= 1 and a step +s >= 1 or *f >= 2)");
      }
      for (std::uint64_t v = first; v < last; v = how == '+' ? v + by : v * by) out.push_back(v);
      out.push_back(last);
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<Design> parse_designs(const std::string& text) {
  if (text == "both") return {Design::AreaEfficient, Design::ManyObject};
  return {hw::parse_design(text)};
}

double modelled_ms(std::uint64_t cycles, double clock_hz) {
  return static_cast<double>(cycles) / clock_hz * 1e3;
}

// ---------------------------------------------------------------- table

struct TableOptions {
  bool json = false;
  bool partitioned = false;
  bool check = false;
  std::uint32_t frames = 3;
  std::uint32_t max_n = 32000;
  unsigned threads = 0;
  bool cost_splits = false;
};

struct TableRow {
  Design design;
  std::uint32_t n;
  std::uint32_t m;
  std::optional<std::uint32_t> cell_limit;
  std::uint64_t cycles;
  double modelled_ms;
  std::optional<double> paper_ms;
};

// Without partitioning: the whole scene is one buffer load, so the cycles
// depend on n alone.
std::vector<TableRow> unpartitioned_rows(const ModelConfig& cfg) {
  std::vector<TableRow> rows;
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    for (const hw::PaperTable4Row& p : hw::paper_table4()) {
      const std::optional<double> paper = d == Design::AreaEfficient ? p.area_efficient_none : p.many_object_none;
      if (!paper) continue;
      const std::uint64_t cycles = hw::analytic_cycles(d, p.n, cfg).total();
      rows.push_back({d, p.n, cfg.m, std::nullopt, cycles, modelled_ms(cycles, cfg.clock_hz), paper});
    }
  }
  return rows;
}

// With partitioning: the paper scenario's frames through the hybrid system,
// whose stats sum the engine's analytic cycles over the cells it formed.
TableRow partitioned_row(Design d, std::uint32_t n, std::uint32_t cell_limit, std::optional<double> paper,
                         const TableOptions& o) {
  BroadPhaseOptions bo;
  bo.engine = d == Design::AreaEfficient ? "ae" : "mo";
  bo.cell_limit = cell_limit;
  bo.threads = o.threads;
  bo.cost_splits = o.cost_splits;
  HybridBroadPhase hybrid(bo);
  ScenarioParams sp;
  sp.n = n;
  Scenario scenario(sp);
  BoxArray boxes;
  std::uint64_t cycles = 0;
  double ms = 0;
  for (std::uint32_t f = 0; f < o.frames; ++f) {
    scenario.compute_boxes(boxes);
    hybrid.update(boxes);
    cycles += hybrid.stats().modelled_cycles;
    ms += hybrid.stats().modelled_ms;
    scenario.step();
  }
  return {d, n, hw::kPaperExtensibility, cell_limit, cycles / o.frames, ms / o.frames, paper};
}

std::vector<TableRow> partitioned_rows(const TableOptions& o) {
  std::vector<TableRow> rows;
  for (const hw::PaperTable4Row& p : hw::paper_table4()) {
    if (p.n > o.max_n) continue;
    if (p.area_efficient_1024) {
      rows.push_back(partitioned_row(Design::AreaEfficient, p.n, 1024, p.area_efficient_1024, o));
    }
    for (int c = 0; c < 5; ++c) {
      if (p.many_object_cells[c]) {
        rows.push_back(partitioned_row(Design::ManyObject, p.n, hw::kPaperCellSizes[c], p.many_object_cells[c], o));
      }
    }
  }
  return rows;
}

nlohmann::json to_json(const TableRow& r) {
  nlohmann::json j;
  j["design"] = hw::design_name(r.design);
  j["n"] = r.n;
  j["m"] = r.m;
  j["cell_limit"] = r.cell_limit ? nlohmann::json(*r.cell_limit) : nlohmann::json(nullptr);
  j["cycles"] = r.cycles;
  j["modelled_ms"] = r.modelled_ms;
  j["paper_ms"] = r.paper_ms ? nlohmann::json(*r.paper_ms) : nlohmann::json(nullptr);
  return j;
}

bool ratio_checked(const TableRow& r) { return !r.cell_limit && r.n >= 300 && r.paper_ms; }
bool ratio_ok(double ratio) { return ratio >= 0.95 && ratio <= 1.05; }

int run_table(const TableOptions& o) {
  ModelConfig cfg;  // the paper's: m = 16, 500 MHz, depth 1024
  cfg.m = hw::kPaperExtensibility;
  cfg.clock_hz = hw::kPaperClockHz;
  std::vector<TableRow> rows = unpartitioned_rows(cfg);
  if (o.partitioned) {
    std::vector<TableRow> more = partitioned_rows(o);
    rows.insert(rows.end(), more.begin(), more.end());
  }
  bool all_ok = true;
  for (const TableRow& r : rows) {
    if (ratio_checked(r)) all_ok &= ratio_ok(r.modelled_ms / *r.paper_ms);
  }
  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const TableRow& r : rows) out.push_back(to_json(r));
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf("Modelled time vs the paper's Table 4 (m = %u, %.0f MHz, pipeline depth %u / %u)\n", cfg.m,
                cfg.clock_hz / 1e6, hw::pipeline_depth(Design::AreaEfficient, cfg),
                hw::pipeline_depth(Design::ManyObject, cfg));
    std::printf("%-15s %8s %4s %6s %11s %12s %10s %7s\n", "design", "n", "m", "cells", "cycles", "modelled ms",
                "paper ms", "ratio");
    for (const TableRow& r : rows) {
      const std::string cells = r.cell_limit ? std::to_string(*r.cell_limit) : "none";
      std::printf("%-15s %8u %4u %6s %11llu %12.4f ", hw::design_name(r.design), r.n, r.m, cells.c_str(),
                  static_cast<unsigned long long>(r.cycles), r.modelled_ms);
      if (r.paper_ms) {
        const double ratio = r.modelled_ms / *r.paper_ms;
        std::printf("%10.4f %7.3f%s\n", *r.paper_ms, ratio, ratio_checked(r) && !ratio_ok(ratio) ? "  <- outside 0.95-1.05" : "");
      } else {
        std::printf("%10s %7s\n", "-", "-");
      }
    }
    std::printf("unpartitioned ratios for n >= 300 within 0.95-1.05: %s\n", all_ok ? "yes" : "NO");
    if (o.partitioned) {
      std::printf("partitioned rows: paper scenario, %u frame(s), seed 0, through the hybrid system%s\n", o.frames,
                  o.cost_splits ? " (cells split below the limit while the modelled cycles drop)" : "");
    }
  }
  return o.check && !all_ok ? 1 : 0;
}

// ---------------------------------------------------------------- explore

struct ExploreOptions {
  std::string n = "100..16384";
  std::string m = "1..32";
  std::string design = "both";
  std::uint32_t depth = 1024;
  double clock_hz = 500e6;
  bool count_load = false;
  bool csv = false;
  bool json = false;
};

// One point of the grid: a design at one m and one n.
struct ExploreRow {
  Design design;
  std::uint64_t n;
  ModelConfig cfg;
  std::uint64_t capacity;
  hw::Counters counters;  // analytic
  double modelled_ms;
  hw::Resources resources;
  std::uint32_t comparators;  // >= and <= together
  std::uint32_t comparisons_per_cycle;
};

// Validates every m before computing anything, so a bad grid prints nothing.
std::vector<ExploreRow> explore_rows(const ExploreOptions& o) {
  const std::vector<std::uint64_t> ns = parse_range(o.n, "--n");
  const std::vector<std::uint64_t> ms = parse_range(o.m, "--m");
  const std::vector<Design> designs = parse_designs(o.design);
  std::vector<ModelConfig> configs;
  for (std::uint64_t m : ms) {
    ModelConfig cfg;
    if (m > hw::kMaxExtensibility) throw InvalidInput("--m: " + std::to_string(m) + " is above 64");
    cfg.m = static_cast<std::uint32_t>(m);
    cfg.depth = o.depth;
    cfg.clock_hz = o.clock_hz;
    cfg.count_load = o.count_load;
    hw::validate(cfg);
    configs.push_back(cfg);
  }
  std::vector<ExploreRow> rows;
  for (Design d : designs) {
    for (const ModelConfig& cfg : configs) {
      const hw::Resources res = hw::resources(d, cfg);
      const std::uint64_t capacity = hw::buffer_capacity(d, cfg);
      for (std::uint64_t n : ns) {
        const hw::Counters k = hw::analytic_counters(d, n, cfg);
        rows.push_back({d, n, cfg, capacity, k, modelled_ms(k.cycles.total(), cfg.clock_hz), res,
                        res.ge_comparators + res.le_comparators, hw::comparisons_per_cycle(d, cfg.m)});
      }
    }
  }
  return rows;
}

void print_explore_json(const std::vector<ExploreRow>& rows) {
  nlohmann::json json = nlohmann::json::array();
  for (const ExploreRow& r : rows) {
    const hw::CycleBreakdown& c = r.counters.cycles;
    json.push_back({{"design", hw::design_name(r.design)},
                    {"n", r.n},
                    {"m", static_cast<std::uint64_t>(r.cfg.m)},
                    {"depth", r.cfg.depth},
                    {"capacity", r.capacity},
                    {"fits", r.n <= r.capacity},
                    {"cycles", c.total()},
                    {"cycles_by_phase",
                     {{"load", c.load}, {"sequence", c.sequence}, {"restart", c.restart}, {"drain", c.drain}}},
                    {"modelled_ms", r.modelled_ms},
                    {"utilisation", r.counters.utilisation()},
                    {"comparisons_per_cycle", r.comparisons_per_cycle},
                    {"memories", r.resources.memories},
                    {"memory_bits", r.resources.memory_bits},
                    {"comparators", r.comparators},
                    {"and_gates", r.resources.and_gates},
                    {"multiplexers", r.resources.multiplexers}});
  }
  std::printf("%s\n", json.dump(2).c_str());
}

void print_explore_csv(const std::vector<ExploreRow>& rows) {
  std::printf("design,n,m,depth,capacity,fits,cycles,sequence,restart,drain,load,modelled_ms,utilisation,"
              "comparisons_per_cycle,memories,memory_bits,comparators,and_gates,multiplexers\n");
  for (const ExploreRow& r : rows) {
    const hw::CycleBreakdown& c = r.counters.cycles;
    std::printf("%s,%llu,%llu,%u,%llu,%d,%llu,%llu,%llu,%llu,%llu,%.9g,%.6f,%u,%u,%llu,%u,%u,%u\n",
                hw::design_name(r.design), static_cast<unsigned long long>(r.n),
                static_cast<unsigned long long>(r.cfg.m), r.cfg.depth, static_cast<unsigned long long>(r.capacity),
                r.n <= r.capacity ? 1 : 0, static_cast<unsigned long long>(c.total()),
                static_cast<unsigned long long>(c.sequence), static_cast<unsigned long long>(c.restart),
                static_cast<unsigned long long>(c.drain), static_cast<unsigned long long>(c.load), r.modelled_ms,
                r.counters.utilisation(), r.comparisons_per_cycle, r.resources.memories,
                static_cast<unsigned long long>(r.resources.memory_bits), r.comparators, r.resources.and_gates,
                r.resources.multiplexers);
  }
}

void print_explore_text(const std::vector<ExploreRow>& rows) {
  std::printf("%-15s %7s %3s %9s %4s %12s %12s %6s %5s %5s %6s\n", "design", "n", "m", "capacity", "fits", "cycles",
              "modelled ms", "util", "cmp/c", "mems", "comps");
  for (const ExploreRow& r : rows) {
    std::printf("%-15s %7llu %3llu %9llu %4s %12llu %12.5f %6.3f %5u %5u %6u\n", hw::design_name(r.design),
                static_cast<unsigned long long>(r.n), static_cast<unsigned long long>(r.cfg.m),
                static_cast<unsigned long long>(r.capacity), r.n <= r.capacity ? "yes" : "NO",
                static_cast<unsigned long long>(r.counters.cycles.total()), r.modelled_ms, r.counters.utilisation(),
                r.comparisons_per_cycle, r.resources.memories, r.comparators);
  }
}

void run_explore(const ExploreOptions& o) {
  if (o.csv && o.json) throw InvalidInput("hw explore: choose one of --csv and --json");
  const std::vector<ExploreRow> rows = explore_rows(o);
  if (o.json) print_explore_json(rows);
  else if (o.csv) print_explore_csv(rows);
  else print_explore_text(rows);
}

// ---------------------------------------------------------------- trace

struct TraceOptions {
  std::string design = "ae";
  std::uint32_t m = 4;
  std::uint32_t n = 10;
  bool tsv = false;
};

void print_aligned(const hw::TableRows& rows) {
  // Width by code points so the many-object symbols (multi-byte UTF-8) align.
  auto width = [](const std::string& s) {
    std::size_t w = 0;
    for (unsigned char c : s) w += (c & 0xC0) != 0x80;
    return w;
  };
  std::vector<std::size_t> widths;
  for (const auto& row : rows) {
    widths.resize(std::max(widths.size(), row.size()), 0);
    for (std::size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], width(row[c]));
  }
  for (const auto& row : rows) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) {
      line.append(widths[c] - width(row[c]) + (c == 0 ? 0 : 1), ' ');
      line.append(row[c]);
    }
    std::printf("%s\n", line.c_str());
  }
}

void run_trace(const TraceOptions& o) {
  const Design d = hw::parse_design(o.design);
  ModelConfig cfg;
  cfg.m = o.m;
  cfg.depth = std::max<std::uint32_t>(cfg.depth, o.n);
  // The address sequence does not depend on the data: disjoint unit boxes.
  BoxArray boxes;
  for (std::uint32_t i = 0; i < o.n; ++i) {
    const float x = 2.0f * static_cast<float>(i);
    boxes.push_back({{x, 0, 0}, {x + 1, 1, 1}});
  }
  std::vector<Pair> pairs;
  hw::TableRows rows;
  hw::Counters k;
  if (d == Design::AreaEfficient) {
    hw::AreaEfficientModel model(cfg);
    hw::AreaEfficientTrace trace;
    k = model.run(boxes, pairs, &trace);
    rows = hw::area_efficient_table(trace, o.n);
  } else {
    hw::ManyObjectModel model(cfg);
    hw::ManyObjectTrace trace;
    k = model.run(boxes, pairs, &trace);
    rows = hw::many_object_table(trace, o.n);
  }
  if (o.tsv) {
    std::printf("%s", hw::to_tsv(rows).c_str());
    return;
  }
  std::printf("%s microarchitecture, m = %u, n = %u: %llu sequence cycles\n", hw::design_name(d), o.m, o.n,
              static_cast<unsigned long long>(k.cycles.sequence));
  print_aligned(rows);
  if (d == Design::ManyObject)
    std::printf("\nColumns (the paper's Table 3): the address on each group's A port (jA), then the object read\n"
                "there; the address on each group's B port (jB), then the object read there; last, each\n"
                "comparator's selector (the B group it reads). An object's mark is the comparator it feeds:\n"
                "%s; a blank object is past n (no comparison).\n",
                o.m <= 4 ? "* comparator 0, \u2020 1, \u2021 2, \u00a7 3" : "[c] comparator c");
  else
    std::printf("\nColumns (the paper's Table 1): the address on each group's A and B ports (blank: past n),\n"
                "then each comparison slot 0-s as anchor-partner (blank: no comparison).\n");
}

// ---------------------------------------------------------------- run

struct RunOptions {
  std::string design = "ae";
  std::uint32_t n = 1000;
  std::uint32_t m = 16;
  std::uint32_t depth = 1024;
  std::string kind = "paper";
  std::uint64_t seed = 0;
  bool count_load = false;
  bool json = false;
};

// One scene through the cycle-by-cycle model, checked against the oracle
// and the analytic cycle count.
struct HwRunResult {
  Design design;
  ModelConfig cfg;
  hw::Counters counters;
  PairSetDiff diff;  // against brute force
  bool analytic_ok;  // simulated cycles == analytic cycles
  double seconds;    // simulator wall time
  double slots_per_second;
};

HwRunResult simulate(const RunOptions& o) {
  const Design d = hw::parse_design(o.design);
  ModelConfig cfg;
  cfg.m = o.m;
  cfg.depth = o.depth;
  cfg.count_load = o.count_load;
  ScenarioParams sp;
  sp.kind = parse_scenario_kind(o.kind);
  sp.n = o.n;
  sp.seed = o.seed;
  Scenario scenario(sp);
  BoxArray boxes;
  scenario.compute_boxes(boxes);

  std::vector<Pair> pairs;
  hw::Counters k;
  const auto start = std::chrono::steady_clock::now();
  if (d == Design::AreaEfficient) {
    hw::AreaEfficientModel model(cfg);
    k = model.run(boxes, pairs);
  } else {
    hw::ManyObjectModel model(cfg);
    k = model.run(boxes, pairs);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::vector<Pair> sorted = pairs;
  canonicalize(sorted);
  PairSetDiff diff = diff_pairs(brute_force_pairs(boxes), sorted);
  const bool analytic_ok = k.cycles == hw::analytic_cycles(d, o.n, cfg);
  const double slots_per_second = seconds > 0 ? static_cast<double>(k.comparator_slots) / seconds : 0.0;
  return {d, cfg, k, std::move(diff), analytic_ok, seconds, slots_per_second};
}

void print_run_json(const RunOptions& o, const HwRunResult& r) {
  const hw::Counters& k = r.counters;
  nlohmann::json j = {{"design", hw::design_name(r.design)},
                      {"n", o.n},
                      {"m", o.m},
                      {"depth", o.depth},
                      {"cycles",
                       {{"load", k.cycles.load},
                        {"sequence", k.cycles.sequence},
                        {"restart", k.cycles.restart},
                        {"drain", k.cycles.drain},
                        {"total", k.cycles.total()}}},
                      {"modelled_ms", modelled_ms(k.cycles.total(), r.cfg.clock_hz)},
                      {"comparator_slots", k.comparator_slots},
                      {"comparisons_performed", k.comparisons_performed},
                      {"comparisons_discarded", k.comparisons_discarded},
                      {"pairs_written", k.pairs_written},
                      {"utilisation", k.utilisation()},
                      {"matches_oracle", r.diff.empty()},
                      {"matches_analytic", r.analytic_ok},
                      {"simulation_seconds", r.seconds},
                      {"simulated_slots_per_second", r.slots_per_second}};
  std::printf("%s\n", j.dump(2).c_str());
}

void print_run_text(const RunOptions& o, const HwRunResult& r) {
  const hw::Counters& k = r.counters;
  std::printf("%s microarchitecture, m = %u, depth = %u, %s scene, n = %u\n", hw::design_name(r.design), o.m,
              o.depth, o.kind.c_str(), o.n);
  std::printf("cycles:      load %llu + sequence %llu + restart %llu + drain %llu = %llu (%.4f ms at %.0f MHz)\n",
              static_cast<unsigned long long>(k.cycles.load), static_cast<unsigned long long>(k.cycles.sequence),
              static_cast<unsigned long long>(k.cycles.restart), static_cast<unsigned long long>(k.cycles.drain),
              static_cast<unsigned long long>(k.cycles.total()), modelled_ms(k.cycles.total(), r.cfg.clock_hz),
              r.cfg.clock_hz / 1e6);
  std::printf("comparisons: %llu performed, %llu discarded, utilisation %.4f\n",
              static_cast<unsigned long long>(k.comparisons_performed),
              static_cast<unsigned long long>(k.comparisons_discarded), k.utilisation());
  std::printf("pairs:       %llu lines written; oracle: %s; analytic cycles: %s\n",
              static_cast<unsigned long long>(k.pairs_written),
              r.diff.empty() ? "identical" : r.diff.summary().c_str(), r.analytic_ok ? "equal" : "DIFFERENT");
  std::printf("simulator:   %.3f s, %.3g comparator slots per second\n", r.seconds, r.slots_per_second);
}

void run_run(const RunOptions& o) {
  const HwRunResult r = simulate(o);
  if (o.json) print_run_json(o, r);
  else print_run_text(o, r);
  if (!r.diff.empty() || !r.analytic_ok)
    throw Error("hw run: the model disagrees with the oracle or its analytic cycles");
}

// ---------------------------------------------------------------- setup

void setup_hw(CLI::App& app) {
  CLI::App* hw = app.add_subcommand("hw", "Cycle-accurate models of the area-efficient and many-object microarchitectures");
  hw->require_subcommand(1);

  auto table = std::make_shared<TableOptions>();
  CLI::App* t = hw->add_subcommand("table", "Modelled time next to the paper's Table 4 (m = 16, 500 MHz)");
  t->add_flag("--json", table->json, "JSON array of rows {design, n, m, cell_limit, cycles, modelled_ms, paper_ms}");
  t->add_flag("--partitioned", table->partitioned,
              "Add the partitioned columns: the paper scenario through the hybrid system with engine ae/mo");
  t->add_flag("--cost-splits", table->cost_splits,
              "Partitioned rows: split cells below the limit while that lowers the modelled cycles (not the paper's rule)");
  t->add_flag("--check", table->check, "Exit with status 1 if an unpartitioned ratio for n >= 300 is outside 0.95-1.05");
  t->add_option("--frames", table->frames, "Frames per partitioned row")->check(CLI::Range(1u, 1000u))->capture_default_str();
  t->add_option("--max-n", table->max_n, "Largest n for partitioned rows (the paper goes to 1,024,000)")
      ->capture_default_str();
  t->add_option("--threads", table->threads, "Threads for the hybrid system (0: all cores)")
      ->check(threads_range())
      ->capture_default_str();
  t->callback([table] {
    const int status = run_table(*table);
    if (status != 0) throw CLI::RuntimeError(status);
  });

  auto explore = std::make_shared<ExploreOptions>();
  CLI::App* e = hw->add_subcommand("explore", "Cycles, time, utilisation, capacity and resources over n and m");
  e->add_option("--n", explore->n, "Object counts: a..b (doubling), a..b:+s, a..b:*f or a list x,y,z")->capture_default_str();
  e->add_option("--m", explore->m, "Extensibility factors, same syntax, 1..64")->capture_default_str();
  e->add_option("--design", explore->design, "ae, mo or both")->capture_default_str();
  e->add_option("--depth", explore->depth, "Words per memory")->check(CLI::Range(1u, 1u << 30))->capture_default_str();
  e->add_option("--clock", explore->clock_hz, "Clock in Hz")->capture_default_str();
  e->add_flag("--count-load", explore->count_load, "Put loading the n AABBs on the modelled clock");
  e->add_flag("--csv", explore->csv, "CSV output");
  e->add_flag("--json", explore->json, "JSON output");
  e->callback([explore] { run_explore(*explore); });

  auto trace = std::make_shared<TraceOptions>();
  CLI::App* tr = hw->add_subcommand("trace", "Per-cycle port addresses and comparisons (the layout of Tables 1 and 3)");
  tr->add_option("--design", trace->design, "ae or mo")->capture_default_str();
  tr->add_option("--m", trace->m, "Extensibility factor")->check(CLI::Range(1u, 64u))->capture_default_str();
  tr->add_option("--n", trace->n, "Objects")->check(CLI::Range(0u, 4096u))->capture_default_str();
  tr->add_flag("--tsv", trace->tsv, "Tab-separated output");
  tr->callback([trace] { run_trace(*trace); });

  auto run = std::make_shared<RunOptions>();
  CLI::App* r = hw->add_subcommand("run", "Simulate one scene cycle by cycle; print counters, check oracle and analytic cycles");
  r->add_option("--design", run->design, "ae or mo")->capture_default_str();
  r->add_option("-n,--n", run->n, "Objects")->capture_default_str();
  r->add_option("--m", run->m, "Extensibility factor")->check(CLI::Range(1u, 64u))->capture_default_str();
  r->add_option("--depth", run->depth, "Words per memory")->check(CLI::Range(1u, 1u << 30))->capture_default_str();
  r->add_option("--kind", run->kind, "Scenario kind")
      ->check(CLI::IsMember({"paper", "clustered", "flat", "huge", "degenerate"}))
      ->capture_default_str();
  r->add_option("--seed", run->seed, "Scenario seed")->capture_default_str();
  r->add_flag("--count-load", run->count_load, "Put loading the n AABBs on the modelled clock");
  r->add_flag("--json", run->json, "JSON output");
  r->callback([run] { run_run(*run); });

  setup_hw_activity(*hw);
  setup_hw_asic(*hw);
  setup_hw_energy(*hw);
}

const RegisterCommand kRegisterHw(setup_hw);

}  // namespace
}  // namespace hbp::cli
