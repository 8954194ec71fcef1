// SPDX-License-Identifier: MIT
// hbp bench paper | kind KIND | scene FILE: the paper's evaluation (Table 4,
// Fig. 4) and every other scene kind against real baselines on the same
// frames, with exact pair sets checked every frame, Table-4-shaped output,
// CSV/JSON of every sample and gnuplot plots.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench_machine.hpp"
#include "bench_gpu.hpp"
#include "bench_narrow_bullet.hpp"
#include "bench_report.hpp"
#include "bench_runner.hpp"
#include "bench_sources.hpp"
#include "child_process.hpp"
#include "command_registry.hpp"
#include "duration_text.hpp"
#include "memory_probe.hpp"
#include "option_checks.hpp"
#include "hbp/error.hpp"
#include "progress.hpp"

namespace hbp::cli {
namespace {

// The rows of the paper's Table 4.
const std::vector<std::uint32_t> kTable4Rows = {100,   200,   300,   400,    500,    600,    700,
                                                800,   900,   1000,  2000,   4000,   8000,   16000,
                                                32000, 64000, 128000, 256000, 512000, 1024000};
// --quick: one row per regime (no partition, small cells, large worlds),
// under 3 minutes on 2 cores.
const std::vector<std::uint32_t> kQuickRows = {100, 1000, 4000, 16000, 64000};
// bench kind: one row per decade up to a million objects.
const std::vector<std::uint32_t> kKindRows = {1000, 10000, 100000, 1000000};
// The degenerate scene stacks a third of its objects as mutually
// overlapping identical boxes: about n^2 / 18 pairs (5.6 million at 10,000,
// 5.6 * 10^10 at 10^6, beyond any memory), so its rows stop early.
const std::vector<std::uint32_t> kDegenerateRows = {1000, 3000, 10000};
constexpr std::uint32_t kDegenerateLimit = 20000;

std::string kind_description(ScenarioKind kind) {
  const std::string common = "sizes 25-75 m, |v| <= 25 m/s, |w| <= 2.5 rad/s per axis, spheres/cuboids/cylinders/"
                             "cones, dt = 1/60 s; variant v uses seed v";
  switch (kind) {
    case ScenarioKind::Paper:
      return "the paper's scenario (section 5): uniform in a cube of side cbrt(50^3 * 5n) m, " + common;
    case ScenarioKind::Clustered:
      return "clustered: the paper's cube, objects in 8 Gaussian clusters (sigma = 5 % of the side), " + common;
    case ScenarioKind::Flat:
      return "flat: the paper's cube, every centre on the plane z = side / 2 (no motion in z), " + common;
    case ScenarioKind::Huge:
      return "huge: the paper's scene plus 4 cuboids spanning 50-90 % of the world per axis, " + common;
    case ScenarioKind::Degenerate:
      return "degenerate: integer lattice, thirds of unit cubes with exactly touching faces, zero-size boxes "
             "on lattice points, stacks of identical 4 m boxes; moves of multiples of 0.25 m per frame";
  }
  return scenario_kind_name(kind);
}

struct BenchArgs {
  std::vector<std::uint32_t> n;
  std::string file;
  std::string kind;  // bench kind: a scenario kind
  std::uint32_t frames = 10, variants = 3, warmup = 3;
  unsigned threads = 1;
  std::string clock = "wall";
  double budget_s = 120;
  std::vector<std::string> budget_for;
  std::vector<std::string> systems;
  bool quick = false, no_plots = false;
  bool print_tables = false;  // --tables: the full tables on stdout too
  std::string gpu_report = kGpuReportPath;
  std::string out;
};

std::string now_text(const char* format) {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, format, &tm);
  return buf;
}

std::string command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> args;
  for (std::string arg; std::getline(in, arg, '\0');) args.push_back(arg);
  return args.empty() ? "hbp bench" : shell_quoted(args);
}

// scripts/plot-bench: next to the sources this binary was built from, or
// next to the binary (build directory inside the source tree).
std::optional<std::string> find_plot_script() {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("HBP_PLOT_BENCH")) candidates.emplace_back(env);
  candidates.push_back(fs::path(__FILE__).parent_path().parent_path().parent_path() / "scripts" / "plot-bench");
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    for (fs::path d = exe.parent_path(); !d.empty() && d != d.root_path(); d = d.parent_path())
      candidates.push_back(d / "scripts" / "plot-bench");
  for (const auto& c : candidates)
    if (fs::exists(c, ec)) return c.string();
  return std::nullopt;
}

enum class BenchSource { Paper, Kind, Scene };

void run_bench(const BenchArgs& a, BenchSource source) {
  const bool paper = source == BenchSource::Paper;
  const bool generated = source != BenchSource::Scene;
  ScenarioKind kind = ScenarioKind::Paper;
  if (source == BenchSource::Kind) kind = parse_scenario_kind(a.kind);
  BenchConfig config;
  config.frames = a.frames;
  config.variants = a.variants;
  config.warmup = a.warmup;
  config.budget_s = a.budget_s;
  for (const auto& item : a.budget_for) {
    const auto eq = item.find('=');
    char* end = nullptr;
    const double seconds = eq == std::string::npos ? -1 : std::strtod(item.c_str() + eq + 1, &end);
    if (eq == std::string::npos || !(seconds > 0) || !std::isfinite(seconds) || end == item.c_str() + eq + 1 ||
        *end != '\0')
      throw InvalidInput("--budget-for: expected SYSTEM=SECONDS with SECONDS > 0, got '" + item + "'");
    config.budget_for.emplace_back(item.substr(0, eq), seconds);
  }
  config.only = a.systems;
  config.choice.threads = a.threads;
  // The full-pipeline column (broad + narrow phase) belongs to the paper's
  // evaluation; the kind benches compare broad phases.
  config.choice.shapes = paper;
  if (a.clock == "cpu") {
    if (a.threads != 1)
      throw InvalidInput("--clock cpu measures the calling thread only: it needs --threads 1 (got --threads " +
                         std::to_string(a.threads) + ")");
    config.choice.clock = BenchClock::Cpu;
  } else if (a.clock != "wall") {
    throw InvalidInput("--clock must be wall or cpu (got '" + a.clock + "')");
  }
  if (config.frames == 0) throw InvalidInput("--frames must be at least 1");
  if (config.variants == 0) throw InvalidInput("--variants must be at least 1");

  std::unique_ptr<SceneFrames> scene;
  std::vector<std::uint32_t> rows;
  BenchHeader header;
  header.command = command_line();
  header.started = now_text("%Y-%m-%dT%H:%M:%S%z");
  header.paper = paper;
  header.gpu_report = a.gpu_report;
  if (generated) {
    const bool degenerate = kind == ScenarioKind::Degenerate;
    rows = a.n.empty() ? (paper ? (a.quick ? kQuickRows : kTable4Rows) : degenerate ? kDegenerateRows : kKindRows)
                       : a.n;
    for (std::uint32_t n : rows) {
      if (n < 2) throw InvalidInput("--n: every object count must be at least 2 (got " + std::to_string(n) + ")");
      if (n > kMaxScenarioObjects)
        throw InvalidInput("--n: " + std::to_string(n) + " objects is more than the scenario limit of " +
                           std::to_string(kMaxScenarioObjects));
      if (degenerate && n > kDegenerateLimit)
        throw InvalidInput("--n " + std::to_string(n) + ": the degenerate scene has about n^2/18 pairs (a third of "
                           "its objects are mutually overlapping identical boxes), " +
                           std::to_string(static_cast<unsigned long long>(double(n) * n / 18)) +
                           " here; bench kind degenerate takes at most " + std::to_string(kDegenerateLimit) +
                           " objects");
    }
    header.title = paper ? "paper scenario" : std::string("scene kind ") + scenario_kind_name(kind);
    header.scene = kind_description(kind);
  } else {
    scene = std::make_unique<SceneFrames>(a.file);
    const std::uint32_t available = scene->frames_after_first();
    if (config.warmup >= available) config.warmup = 0;
    if (config.warmup + config.frames > available) config.frames = available - config.warmup;
    config.variants = 1;
    rows = {scene->object_count()};
    header.title = "scene " + a.file;
    header.scene = a.file + " (" + scene_format_name(scene->info().format) + ", " +
                   std::to_string(scene->object_count()) + " objects, " +
                   std::to_string(scene->info().frame_count) + " frames; frame 0 sets up)";
  }
  header.config = config;
  header.machine = describe_machine();
  header.machine.emplace_back("memory latency at start", memory_latency_text(probe_memory_latency()));

  const std::string out =
      !a.out.empty() ? a.out
                     : "bench-results/" +
                           (paper ? std::string("paper")
                                  : generated ? std::string("kind-") + scenario_kind_name(kind) : std::string("scene")) +
                           "-" + now_text("%Y%m%d-%H%M%S");

  std::fprintf(stderr, "hbp bench: %s, %zu row(s), %u variant(s) x %u frame(s) (+%u warm-up), budget %s per "
               "system per row, %u thread(s), %s clock; the paper used 20 x 1000\n",
               header.title.c_str(), rows.size(), config.variants, config.frames, config.warmup,
               format_duration(config.budget_s).c_str(), config.choice.threads, a.clock.c_str());
  std::fprintf(stderr, "machine: %s\n", machine_summary(header.machine).c_str());

  double total_work = 0;
  for (std::uint32_t n : rows) total_work += n * double(config.variants) * (config.warmup + config.frames + 1);
  ProgressBar bar("bench", static_cast<std::uint64_t>(total_work / 1000), "k object-frames");
  auto log = [&](const std::string& line) {
    if (bar.enabled()) std::fputs("\r\033[K", stderr);
    std::fprintf(stderr, "%s\n", line.c_str());
  };
  auto progress = [&](double done, double, const std::string&) { bar.update(static_cast<std::uint64_t>(done / 1000)); };

  const auto t0 = std::chrono::steady_clock::now();
  BenchRunner runner(config, progress, log);
  runner.plan(rows);
  for (std::uint32_t n : rows) {
    if (generated) {
      PaperFrames frames(n, kind);
      runner.run_row(frames);
    } else {
      runner.run_row(*scene);
    }
    if (!bar.enabled()) {
      // Without a terminal, one line per finished row keeps logs informative.
      const auto& row = runner.result().rows.back();
      std::fprintf(stderr, "  n=%u done (%s elapsed)\n", row.n,
                   format_duration(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count())
                       .c_str());
    }
  }
  bar.finish();
  BenchResult& result = runner.result();
  result.total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  header.machine.emplace_back("memory latency at end", memory_latency_text(probe_memory_latency()));
  header.machine.emplace_back("load average at end", read_load_average());

  // The full tables (every system, every statistic) are the report's
  // tables.md; the terminal gets a summary unless --tables asks for them.
  const auto files = write_report_files(out, result, header);
  std::fputs((a.print_tables ? format_tables(result, header) + "\n" : format_summary(result)).c_str(), stdout);
  std::printf("Report: %s/tables.md (the full tables), summary.csv, samples.csv (every per-frame sample), "
              "report.json\n",
              out.c_str());
  std::string plot_error;  // why the plot script failed, if it did
  if (!a.no_plots && result.rows.size() < 2) {
    std::printf("Plots: none (one object count; the plots are curves over n)\n");
  } else if (!a.no_plots) {
    const auto script = find_plot_script();
    if (!script) {
      std::printf("Plots: scripts/plot-bench not found; run it by hand: %s\n",
                  shell_quoted({"scripts/plot-bench", out}).c_str());
    } else {
      std::fflush(stdout);
      try {
        run_program({"bash", *script, out});
        if (std::filesystem::exists(std::filesystem::path(out) / "accel.png"))
          std::printf("Plots: %s/accel.png, accel.svg (acceleration vs n, like Fig. 4), times.png, times.svg\n",
                      out.c_str());
        else  // the script draws no acceleration without Bullet DBVT's times
          std::printf("Plots: %s/times.png, times.svg (no acceleration plot: bullet-dbvt not measured)\n",
                      out.c_str());
      } catch (const Error& e) {
        std::printf("Plots: %s failed (is gnuplot installed? scripts/install-deps)\n",
                    shell_quoted({"bash", *script, out}).c_str());
        std::fflush(stdout);  // before the error message on stderr
        plot_error = e.what();
      }
    }
  }
  if (!result.mismatches.empty())
    throw Error(std::to_string(result.mismatches.size()) + " frame(s) where a system's pairs differed from " +
                result.reference + "'s (listed above)" + (plot_error.empty() ? "" : "; plots: " + plot_error));
  // The tables and report files are written; the run still fails so scripts notice the missing plots.
  if (!plot_error.empty()) throw Error("plots: " + plot_error);
}

void add_common(CLI::App* cmd, BenchArgs& a) {
  cmd->add_option("--frames", a.frames, "Timed frames per variant")->capture_default_str();
  cmd->add_option("--warmup", a.warmup,
                  "Untimed frames after setup, per variant (Bullet's DBVT needs a few to optimise its trees)")
      ->capture_default_str();
  cmd->add_option("--threads", a.threads, "Threads for our software hybrid (baselines are single-threaded)")
      ->check(threads_range())
      ->capture_default_str();
  cmd->add_option("--clock", a.clock,
                  "wall: elapsed time (what a user waits); cpu: CPU time of the calling thread, robust to other "
                  "load on a shared machine (needs --threads 1)")
      ->check(CLI::IsMember({"wall", "cpu"}))
      ->capture_default_str();
  cmd->add_option("--budget", a.budget_s, "Seconds per system per row; skip systems projected beyond it")
      ->check(positive_finite())
      ->capture_default_str();
  cmd->add_option("--budget-for", a.budget_for,
                  "Per-system budgets, SYSTEM=SECONDS (comma list), e.g. bullet-axis-sweep=30,brute=30")
      ->delimiter(',');
  cmd->add_option("--systems", a.systems, "Only these systems (comma list): bullet-dbvt, bullet-dbvt-deferred, "
                                           "bullet-axis-sweep, cgal, fcl-dynamic-aabb-tree, fcl-sap, "
                                           "fcl-interval-tree, fcl-spatial-hash, ode-hash, ode-sap, ode-quadtree, "
                                           "brute, sw, sw-sorted, sw-narrow, cuda (the GPU frame, with a CUDA "
                                           "device), cuda-axis-sweep, cuda-lbvh (its GPU peers), ae-none, "
                                           "ae-1024, mo-none, mo-1024 ... mo-16384")
      ->delimiter(',');
  cmd->add_option("--out", a.out, "Output directory (default bench-results/<kind>-<time>)");
  cmd->add_option("--gpu-report", a.gpu_report, "The stored GPU run for the GPU column (bench paper)")
      ->capture_default_str();
  cmd->add_flag("--no-plots", a.no_plots, "Do not run gnuplot");
  cmd->add_flag("--tables", a.print_tables, "Print the full tables (the report's tables.md) instead of the summary");
}

const RegisterCommand reg([](CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks against Bullet, CGAL and the paper's Table 4");
  bench->require_subcommand(1);

  auto pa = std::make_shared<BenchArgs>();
  CLI::App* paper = bench->add_subcommand(
      "paper", "The paper's scenario for each n: every engine and baseline on the same frames (Table 4, Fig. 4). "
               "The default (every row to 1,024,000, 3 variants x 10 frames, each system stopped at its 120 s "
               "budget per row and projected beyond) runs for an hour or more on 2 cores; 1 variant x 2 frames took "
               "20 minutes (docs/results.md); --quick under 3");
  paper->add_option("--n", pa->n, "Object counts (comma list; default: Table 4's rows 100 ... 1,024,000)")
      ->delimiter(',');
  paper->add_option("--variants", pa->variants, "Variants (seeds) per row")->capture_default_str();
  paper->add_flag("--quick", pa->quick,
                  "A few rows (100, 1000, 4000, 16000, 64000), 1 variant x 5 frames after 2 warm-up frames, "
                  "20 s budget: under 3 minutes on 2 cores");
  add_common(paper, *pa);
  paper->callback([pa, paper] {
    BenchArgs a = *pa;
    if (a.quick) {
      if (paper->count("--frames") == 0) a.frames = 5;
      if (paper->count("--variants") == 0) a.variants = 1;
      if (paper->count("--warmup") == 0) a.warmup = 2;
      if (paper->count("--budget") == 0) a.budget_s = 20;
    }
    run_bench(a, BenchSource::Paper);
  });

  auto ka = std::make_shared<BenchArgs>();
  CLI::App* kind = bench->add_subcommand(
      "kind", "One scene kind (paper, clustered, flat, huge, degenerate) for each n: every engine and baseline on "
              "the same frames, systems over budget projected");
  kind->add_option("kind", ka->kind, "Scene kind: paper, clustered, flat, huge, degenerate")
      ->required()
      ->check(CLI::IsMember({"paper", "clustered", "flat", "huge", "degenerate"}));
  kind->add_option("--n", ka->n,
                   "Object counts (comma list; default 1000,10000,100000,1000000; degenerate: 1000,3000,10000, "
                   "at most 20000)")
      ->delimiter(',');
  kind->add_option("--variants", ka->variants, "Variants (seeds) per row")->capture_default_str();
  add_common(kind, *ka);
  kind->callback([ka, kind] {
    BenchArgs a = *ka;
    // Defaults sized so the four decades up to 10^6 finish within 15 minutes
    // on 2 cores: 1 variant x 10 timed frames after 2 warm-up frames, 20 s
    // per system per row (projected beyond).
    if (kind->count("--frames") == 0) a.frames = 10;
    if (kind->count("--variants") == 0) a.variants = 1;
    if (kind->count("--warmup") == 0) a.warmup = 2;
    if (kind->count("--budget") == 0) a.budget_s = 20;
    run_bench(a, BenchSource::Kind);
  });

  auto sa = std::make_shared<BenchArgs>();
  CLI::App* scene = bench->add_subcommand("scene", "Every engine and baseline on a recorded scene (native or "
                                                   "Broadmark .aabbs), same tables");
  scene->add_option("file", sa->file, "Scene file")->required();
  add_common(scene, *sa);
  scene->callback([sa] { run_bench(*sa, BenchSource::Scene); });

  add_bench_narrow(bench);
  add_bench_gpu(bench);
});

}  // namespace
}  // namespace hbp::cli
