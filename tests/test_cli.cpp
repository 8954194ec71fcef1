// SPDX-License-Identifier: MIT
// The `hbp` tool refuses bad input up front: each case runs the real binary
// (HBP_CLI_PATH, built with the tests) and expects a non-zero exit and a
// message naming the offending option, value or limit — never std::bad_alloc,
// never exit 0 with an empty result.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;

struct Result {
  int status = -1;     // exit status (-1: did not exit normally)
  std::string output;  // stdout and stderr, interleaved
};

// Runs hbp with `args`; `env` entries NAME=VALUE replace or add variables.
Result hbp(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  std::vector<std::string> env_store;
  for (char** e = environ; *e != nullptr; ++e) {
    bool replaced = false;
    for (const std::string& v : env)
      replaced |= std::strncmp(*e, v.c_str(), v.find('=') + 1) == 0;
    if (!replaced) env_store.emplace_back(*e);
  }
  for (const std::string& v : env) env_store.push_back(v);
  std::vector<char*> envp;
  for (std::string& s : env_store) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_store = {HBP_CLI_PATH};
  argv_store.insert(argv_store.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_store) argv.push_back(s.data());
  argv.push_back(nullptr);

  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, HBP_CLI_PATH, &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (rc != 0) {
    close(fds[0]);
    throw std::runtime_error("posix_spawn " HBP_CLI_PATH " failed");
  }
  Result r;
  char buf[4096];
  for (ssize_t got; (got = read(fds[0], buf, sizeof buf)) > 0;) r.output.append(buf, static_cast<std::size_t>(got));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string joined(const std::vector<std::string>& args) {
  std::string s = "hbp";
  for (const auto& a : args) s += " " + a;
  return s;
}

// Non-zero exit (not a crash) and every part in the output; no bad_alloc.
void expect_refused(const std::vector<std::string>& args, const std::vector<std::string>& parts,
                    const std::vector<std::string>& env = {}) {
  const Result r = hbp(args, env);
  EXPECT_GT(r.status, 0) << joined(args) << ":\n" << r.output;
  for (const auto& part : parts)
    EXPECT_NE(r.output.find(part), std::string::npos) << joined(args) << ": '" << part << "' not in:\n" << r.output;
  EXPECT_EQ(r.output.find("bad_alloc"), std::string::npos) << joined(args) << ":\n" << r.output;
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hbp_test_cli_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A valid native scene with `frames` frames of `n` unit cubes.
  std::string scene(const std::string& name, std::uint32_t n, std::uint32_t frames) const {
    const std::string file = path(name);
    hbp::SceneWriter w(file, hbp::SceneFormat::Native, n, {{0, 0, 0}, {10, 10, 10}}, "test", "box");
    hbp::BoxArray boxes(n);
    for (std::uint32_t i = 0; i < n; ++i) boxes.set(i, {{float(i), 0, 0}, {float(i) + 1.5f, 1, 1}});
    for (std::uint32_t k = 0; k < frames; ++k) w.write_frame(boxes);
    w.close();
    return file;
  }

 private:
  fs::path dir_;
};

TEST_F(Cli, BadSimdChoiceIsAnErrorNamingTheAcceptedValues) {
  for (const char* value : {"bogus", "AVX2", "Scalar", "avx", "avx512 "}) {
    expect_refused({"run", "--n", "50", "--frames", "1"}, {std::string("HBP_SIMD=") + value, "scalar, avx2 or avx512"},
                   {std::string("HBP_SIMD=") + value});
  }
  // Every command, not only those running the software engine.
  expect_refused({"hw", "trace", "--n", "4"}, {"HBP_SIMD=bogus"}, {"HBP_SIMD=bogus"});
  // The accepted values work (an ISA the CPU lacks falls back, as documented).
  const Result r = hbp({"run", "--n", "50", "--frames", "1", "--json"}, {"HBP_SIMD=scalar"});
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"simd\": \"scalar\""), std::string::npos) << r.output;
}

TEST_F(Cli, NothingToComputeIsAnError) {
  expect_refused({"run", "--frames", "0"}, {"--frames", "0"});
  const std::string empty = scene("empty.hbps", 10, 0);
  // A zero-frame file is a valid file: `scene info` describes it ...
  const Result info = hbp({"scene", "info", empty, "--validate"});
  EXPECT_EQ(info.status, 0) << info.output;
  EXPECT_NE(info.output.find("frames:       0"), std::string::npos) << info.output;
  // ... but `run` and `pairs` have nothing to compute.
  expect_refused({"run", "--in", empty}, {empty, "no frames"});
  expect_refused({"pairs", empty}, {empty, "no frames"});
  expect_refused({"pairs", empty, "--engine", "sw"}, {empty, "no frames"});
  // One frame is enough.
  const std::string one = scene("one.hbps", 10, 1);
  const Result run = hbp({"run", "--in", one, "--quiet"});
  EXPECT_EQ(run.status, 0) << run.output;
  const Result pairs = hbp({"pairs", one});
  EXPECT_EQ(pairs.status, 0) << pairs.output;
  EXPECT_NE(pairs.output.find("0 1\n"), std::string::npos) << pairs.output;
}

// The keys outside programs read from `hbp run --json` (first, worst and
// p99 frame beside the median; the partition's maintenance,
// spread rebuilds included). The first frame builds from scratch.
TEST_F(Cli, RunJsonNamesFrameTimesAndMaintenance) {
  const Result r = hbp({"run", "--n", "3000", "--frames", "3", "--threads", "2", "--json", "--quiet"});
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* key : {"\"first_wall_ms\"", "\"max_wall_ms\"", "\"p99_wall_ms\"", "\"median_wall_ms\"",
                          "\"rebuilt\"", "\"rebuilt_subtrees\"", "\"rebuilt_entries\"", "\"splits\"",
                          "\"merges\""})
    EXPECT_NE(r.output.find(key), std::string::npos) << key << " missing from\n" << r.output;
  EXPECT_NE(r.output.find("\"rebuilt\": true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"rebuilt_subtrees\": 0"), std::string::npos) << r.output;
}

// `hbp run` provisions the frames' memory before frame 0 unless told not
// to (reserve_ms, outside every frame); the frames' pairs are the same.
TEST_F(Cli, RunReservesBeforeFrameZeroUnlessToldNot) {
  const std::vector<std::string> base = {"run", "--n", "5000", "--frames", "3", "--threads", "2", "--json", "--quiet"};
  auto pair_counts = [](const std::string& out) {
    std::vector<std::string> counts;
    const std::string key = "\"pairs\": ";
    for (std::size_t at = out.find(key); at != std::string::npos; at = out.find(key, at + 1))
      counts.push_back(out.substr(at + key.size(), out.find_first_of(",\n", at + key.size()) - at - key.size()));
    return counts;
  };
  const Result reserved = hbp(base);
  std::vector<std::string> args = base;
  args.push_back("--no-reserve");
  const Result unreserved = hbp(args);
  ASSERT_EQ(reserved.status, 0) << reserved.output;
  ASSERT_EQ(unreserved.status, 0) << unreserved.output;
  EXPECT_NE(reserved.output.find("\"reserve\": true"), std::string::npos) << reserved.output;
  EXPECT_NE(reserved.output.find("\"reserve_ms\": "), std::string::npos) << reserved.output;
  EXPECT_NE(unreserved.output.find("\"reserve\": false"), std::string::npos) << unreserved.output;
  EXPECT_NE(unreserved.output.find("\"reserve_ms\": 0.0"), std::string::npos) << unreserved.output;
  const auto counts = pair_counts(reserved.output);
  ASSERT_EQ(counts.size(), 3u) << reserved.output;
  EXPECT_NE(counts[0], "0");
  EXPECT_EQ(counts, pair_counts(unreserved.output));
}

TEST_F(Cli, NativeLayoutFieldIsReportedAsSuch) {
  const std::string file = scene("layout.hbps", 10, 2);
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    const std::uint32_t layout = 1;
    f.seekp(48);
    f.write(reinterpret_cast<const char*>(&layout), sizeof layout);
  }
  for (const char* command : {"info", "run", "pairs"}) {
    std::vector<std::string> args = {"scene", "info", file};
    if (std::string(command) == "run") args = {"run", "--in", file};
    if (std::string(command) == "pairs") args = {"pairs", file};
    expect_refused(args, {file, "unsupported native frame layout 1"});
    EXPECT_EQ(hbp(args).output.find("reserved"), std::string::npos) << command;
  }
}

TEST_F(Cli, ScenarioParametersAreCheckedBeforeWriting) {
  const std::string out = path("x.hbps");
  auto gen = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = {"scene", "gen", "-o", out, "--frames", "2"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  expect_refused(gen({"--kind", "clustered", "--cluster-sigma", "-1", "-n", "10"}), {"cluster sigma", "-1"});
  expect_refused(gen({"--kind", "clustered", "--cluster-sigma", "nan", "-n", "10"}), {"cluster sigma"});
  expect_refused(gen({"--kind", "clustered", "--cluster-sigma", "0", "-n", "10"}), {"cluster sigma"});
  expect_refused(gen({"--kind", "huge", "--huge-objects", "11", "-n", "10"}), {"huge objects (11)", "n = 10"});
  expect_refused(gen({"--dt", "nan", "-n", "10"}), {"dt"});
  expect_refused(gen({"--dt", "-0.1", "-n", "10"}), {"dt"});
  expect_refused(gen({"--size-min", "nan", "-n", "10"}), {"size"});
  expect_refused(gen({"--size-max", "inf", "-n", "10"}), {"size"});
  expect_refused(gen({"--linear-speed", "-1", "-n", "10"}), {"linear speed"});
  expect_refused(gen({"--angular-speed", "nan", "-n", "10"}), {"angular speed"});
  expect_refused(gen({"--volume-per-object", "0", "-n", "10"}), {"volume per object"});
  expect_refused(gen({"--volume-per-object", "1e300", "-n", "10"}), {"1e30"});
  expect_refused(gen({"--kind", "clustered", "--clusters", "0", "-n", "10"}), {"cluster"});
  EXPECT_FALSE(fs::exists(out)) << "a refused scene must not leave a file behind";
  // The boundary values are accepted.
  const Result ok = hbp(gen({"--kind", "huge", "--huge-objects", "10", "-n", "10"}));
  EXPECT_EQ(ok.status, 0) << ok.output;
}

TEST_F(Cli, SizesPastTheLimitAreRefusedUpFrontNamingIt) {
  const std::string limit = std::to_string(hbp::kMaxScenarioObjects);
  expect_refused({"scene", "gen", "-n", "2147483647", "-o", path("big.hbps")}, {"2147483647", limit});
  expect_refused({"run", "--n", "4000000000", "--frames", "1"}, {"4000000000", limit});
  expect_refused({"run", "--n", "67108865", "--frames", "1"}, {"67108865", limit});
  expect_refused({"render", "--n", "4000000000", "--out", path("x.png")}, {"4000000000", limit});
  expect_refused({"hw", "run", "--n", "4000000000"}, {"4000000000"});
  expect_refused({"bench", "paper", "--n", "100,4000000000", "--out", path("bench")}, {"4000000000", limit});
  expect_refused({"render", "--width", "100000", "--height", "100000", "--out", path("x.png")}, {"--width"});
  expect_refused({"render", "--samples", "1000", "--out", path("x.png")}, {"--samples"});
  // The cycle-by-cycle buffer is bounded (the analytic commands are not).
  expect_refused({"hw", "run", "--depth", "1073741824", "--m", "64", "-n", "10"}, {"16777216"});
  for (const char* command : {"run", "pairs", "render"}) {
    std::vector<std::string> args = {command, "--threads", "5000"};
    if (std::string(command) == "pairs") args.insert(args.begin() + 1, path("none.hbps"));
    expect_refused(args, {"--threads", "5000"});
  }
  expect_refused({"bench", "paper", "--threads", "5000"}, {"--threads"});
  expect_refused({"hw", "table", "--threads", "5000"}, {"--threads"});
}

TEST_F(Cli, BenchBudgetsMustBePositiveNumbers) {
  for (const char* budget : {"-1", "nan", "0", "inf", "-inf", "abc"})
    expect_refused({"bench", "paper", "--n", "100", "--budget", budget, "--out", path("b")}, {"--budget"});
  for (const char* item : {"brute=nan", "brute=-1", "brute=0", "brute=inf", "brute", "brute=1x"})
    expect_refused({"bench", "paper", "--n", "100", "--budget-for", item, "--out", path("b")}, {"--budget-for", item});
  expect_refused({"bench", "paper", "--n", "100", "--frames", "0", "--out", path("b")}, {"--frames"});
  expect_refused({"bench", "paper", "--n", "100", "--variants", "0", "--out", path("b")}, {"--variants"});
  EXPECT_FALSE(fs::exists(path("b")));
}

TEST_F(Cli, RenderCountsMustBePositive) {
  expect_refused({"render", "--width", "0", "--out", path("x.png")}, {"--width"});
  expect_refused({"render", "--samples", "0", "--out", path("x.png")}, {"--samples"});
  expect_refused({"render", "--video", path("v"), "--frames", "0"}, {"--frames"});
}

// `hbp bench` runs its plot script with an argument vector, no shell: an
// output directory with spaces, quotes and `$` reaches the script unchanged,
// and a script that fails or cannot be started makes the run fail, naming
// the command and why (after the report files are written).
TEST_F(Cli, BenchPlotScriptRunsWithoutAShellAndItsFailuresAreErrors) {
  const std::string out = path("out dir 'q\" $HOME");
  const std::vector<std::string> bench = {"bench", "kind", "degenerate", "--n", "300,600", "--frames", "1",
                                          "--warmup", "0", "--systems", "brute,sw,bullet-dbvt", "--out", out};
  auto stub = [&](const std::string& name, const std::string& body) {
    const std::string file = path(name);
    std::ofstream(file) << body;
    return "HBP_PLOT_BENCH=" + file;
  };
  // The directory as the script sees it.
  const Result echo = hbp(bench, {stub("echo.sh", "printf '%s' \"$1\" > \"$1/argv.txt\"\n")});
  ASSERT_EQ(echo.status, 0) << echo.output;
  std::ifstream argv_file(out + "/argv.txt");
  std::string seen((std::istreambuf_iterator<char>(argv_file)), std::istreambuf_iterator<char>());
  EXPECT_EQ(seen, out);
  // A failing script: non-zero exit, its status and command named; the report is still written.
  fs::remove_all(out);
  expect_refused(bench, {"plots: exit status 3 from: bash", "fail.sh", "out dir"}, {stub("fail.sh", "exit 3\n")});
  EXPECT_TRUE(fs::exists(out + "/summary.csv"));
  // bash not found on PATH.
  expect_refused(bench, {"cannot start 'bash'", "No such file or directory"},
                 {stub("echo2.sh", "exit 0\n"), "PATH=" + path("no such dir")});
  // The real script and gnuplot draw into the directory.
  fs::remove_all(out);
  const Result real = hbp(bench);
  ASSERT_EQ(real.status, 0) << real.output;
  EXPECT_TRUE(fs::exists(out + "/accel.png")) << real.output;
  EXPECT_TRUE(fs::exists(out + "/times.svg")) << real.output;
}

}  // namespace

namespace {

// `hbp bench`'s hybrid runs twice: "sw" with its pairs in cell order (like
// the peers' unordered sets; the pair-set check sorts a copy) and "sw-sorted"
// with the library's default sorted list. Both must match the brute-force
// oracle every frame: a reference list left unsorted for the check would
// show as a mismatch of every other system.
TEST_F(Cli, BenchRunsTheHybridInCellOrderAndSorted) {
  const Result r = hbp({"bench", "paper", "--n", "300,2000", "--frames", "2", "--warmup", "0", "--variants", "1",
                        "--systems", "brute,sw,sw-sorted", "--no-plots", "--out", path("b")});
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("MISMATCH n="), std::string::npos) << r.output;  // the log line of a differing frame
  // The full tables are the report's tables.md.
  std::ifstream tables_file(path("b") + "/tables.md");
  const std::string tables((std::istreambuf_iterator<char>(tables_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(tables.find("| hybrid sw (m) |"), std::string::npos) << tables;
  EXPECT_NE(tables.find("| hybrid sw, sorted (m) |"), std::string::npos) << tables;
  EXPECT_NE(tables.find("Every system that ran found exactly the reference's pairs in every timed frame."),
            std::string::npos)
      << tables;
  // The machine's state around the run: the memory probe before and after.
  for (const char* when : {"start", "end"}) {
    const std::string key = std::string("- memory latency at ") + when + ": ";
    const std::size_t at = tables.find(key);
    ASSERT_NE(at, std::string::npos) << tables;
    EXPECT_GT(std::atof(tables.c_str() + at + key.size()), 0.0) << tables.substr(at, 100);
  }
}

TEST_F(Cli, DepthToleranceIsCheckedAndReported) {
  expect_refused({"run", "--n", "200", "--frames", "1", "--depth-tolerance", "1e-4"}, {"--depth-tolerance", "--narrow"});
  for (const char* value : {"0", "-1", "nan", "0.5"}) {
    expect_refused({"run", "--n", "200", "--frames", "1", "--narrow", "--depth-tolerance", value},
                   {"depth_tolerance", "outside"});
    expect_refused({"bench", "narrow", "--n", "200", "--frames", "2", "--runs", "1", "--no-bullet",
                    "--depth-tolerance", value},
                   {"depth_tolerance", "outside"});
  }
  const Result r = hbp({"run", "--n", "200", "--frames", "2", "--narrow", "--depth-tolerance", "1e-05", "--json"});
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"depth_tolerance\": 1e-05"), std::string::npos) << r.output;
  // bench narrow at that tolerance: it runs, says so, and records the
  // machine's memory state before and after.
  const Result b = hbp({"bench", "narrow", "--n", "300", "--frames", "2", "--runs", "1", "--no-bullet",
                        "--depth-tolerance", "1e-05"});
  ASSERT_EQ(b.status, 0) << b.output;
  EXPECT_NE(b.output.find("depth tolerance 1e-05 relative"), std::string::npos) << b.output;
  for (const char* key : {"memory latency at start: ", "memory latency at end: "}) {
    const std::size_t at = b.output.find(key);
    ASSERT_NE(at, std::string::npos) << b.output;
    EXPECT_GT(std::atof(b.output.c_str() + at + std::strlen(key)), 0.0) << b.output.substr(at, 100);
  }
}

// --version prints the project's version and exits 0, like --help.
TEST_F(Cli, VersionPrintsTheVersionAndExitsZero) {
  const Result r = hbp({"--version"});
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output, std::string("hbp ") + HBP_EXPECTED_VERSION + "\n");
  const Result h = hbp({"--help"});
  EXPECT_EQ(h.status, 0) << h.output;
  EXPECT_NE(h.output.find("--version"), std::string::npos) << h.output;
}

// The exit status convention of docs/cli.md: 0 success, 1 the command ran and
// failed, 2 the command line does not parse.
TEST_F(Cli, ExitStatusIsZeroOneOrTwo) {
  // 2: usage errors, each naming what is wrong.
  const std::vector<std::pair<std::vector<std::string>, std::string>> usage = {
      {{}, "A subcommand is required"},
      {{"no-such-command"}, "no-such-command"},
      {{"run", "--no-such-option"}, "--no-such-option"},
      {{"run", "--n", "many"}, "--n"},
      {{"run", "--threads", "5000"}, "--threads"},
  };
  for (const auto& [args, part] : usage) {
    const Result r = hbp(args);
    EXPECT_EQ(r.status, 2) << joined(args) << ":\n" << r.output;
    EXPECT_NE(r.output.find(part), std::string::npos) << joined(args) << ": '" << part << "' not in:\n" << r.output;
  }
  // 1: the command ran and failed (a file it cannot read, a value it rejects).
  const Result missing = hbp({"pairs", path("no-such-scene.hbps")});
  EXPECT_EQ(missing.status, 1) << missing.output;
  EXPECT_NE(missing.output.find("no-such-scene.hbps"), std::string::npos) << missing.output;
  const Result bad = hbp({"render", "--n", "10"});  // neither --out nor --video
  EXPECT_EQ(bad.status, 1) << bad.output;
  EXPECT_NE(bad.output.find("--out"), std::string::npos) << bad.output;
  // 0
  const Result ok = hbp({"run", "--n", "50", "--frames", "1"});
  EXPECT_EQ(ok.status, 0) << ok.output;
}

// render checks that it can write --out before it renders, and says why not.
TEST_F(Cli, RenderSaysWhyItCannotWrite) {
  const Result r = hbp({"render", "--n", "10", "--out", "/nonexistent/x.png"});
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("--out '/nonexistent/x.png'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("directory '/nonexistent' does not exist"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("Mrays/s"), std::string::npos) << "rendered before refusing:\n" << r.output;
  // A path whose directory is a file.
  std::ofstream(path("file")) << "x";
  const Result f = hbp({"render", "--n", "10", "--out", path("file") + "/x.png"});
  EXPECT_EQ(f.status, 1) << f.output;
  EXPECT_NE(f.output.find("is not a directory"), std::string::npos) << f.output;
  EXPECT_FALSE(fs::exists(path("file") + "/x.png"));
  // The same command with a writable path renders.
  const Result ok = hbp({"render", "--n", "10", "--width", "32", "--height", "32", "--samples", "1", "--out",
                         path("ok.png")});
  EXPECT_EQ(ok.status, 0) << ok.output;
  EXPECT_GT(fs::file_size(path("ok.png")), 0u);
}

// bench prints a short summary and the report's path; the full tables are in
// tables.md (and on stdout with --tables).
TEST_F(Cli, BenchPrintsASummaryAndTheReportPath) {
  const std::string out = path("bench");
  const std::vector<std::string> args = {"bench", "kind", "degenerate", "--n", "300,600", "--frames", "1", "--warmup",
                                         "0", "--systems", "brute,sw,bullet-dbvt", "--no-plots", "--out", out};
  const Result r = hbp(args);
  ASSERT_EQ(r.status, 0) << r.output;
  for (const std::string& part : {std::string("n = 300, "), std::string("n = 600, "), std::string("fastest "),
                                  std::string("matched"), "Report: " + out + "/tables.md"})
    EXPECT_NE(r.output.find(part), std::string::npos) << "'" << part << "' not in:\n" << r.output;
  EXPECT_EQ(r.output.find("## Median time per frame"), std::string::npos) << "full tables printed:\n" << r.output;
  std::ifstream tables_file(out + "/tables.md");
  const std::string tables((std::istreambuf_iterator<char>(tables_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(tables.find("## Median time per frame"), std::string::npos);
  // The summary is short: a line per object count and a few more.
  std::size_t lines = 0;
  for (char c : r.output) lines += c == '\n';
  EXPECT_LT(lines, 20u) << r.output;

  std::vector<std::string> with_tables = args;
  with_tables.push_back("--tables");
  const Result t = hbp(with_tables);
  ASSERT_EQ(t.status, 0) << t.output;
  EXPECT_NE(t.output.find("## Median time per frame"), std::string::npos) << t.output;
}

// bench paper's GPU column comes from a stored GPU run, labelled with its
// GPU and date; without one (or from a dry run) it reads not measured.
// The GPU frame and its peers as bench systems ("cuda", "cuda-axis-sweep",
// "cuda-lbvh"): columns beside the others with a CUDA device, their pairs
// checked like every system's; without one, named among the systems not
// built, and the run goes on.
TEST_F(Cli, BenchRunsTheGpuFrameWhereThereIsADevice) {
  const std::string out = path("bench-cuda");
  const Result r = hbp({"bench", "kind", "paper", "--n", "400", "--frames", "2", "--warmup", "0", "--systems",
                        "sw,cuda,cuda-axis-sweep,cuda-lbvh", "--no-plots", "--out", out});
  ASSERT_EQ(r.status, 0) << r.output;
  nlohmann::json j;
  std::ifstream(out + "/report.json") >> j;
  int columns = 0;
  for (const auto& s : j["systems"])
    columns += s["key"] == "cuda" || s["key"] == "cuda-axis-sweep" || s["key"] == "cuda-lbvh";
  bool named = false;
  for (const auto& m : j["not_built"])
    named |= m.get<std::string>().find("GPU frame 'cuda' and its peers 'cuda-axis-sweep', 'cuda-lbvh'") !=
             std::string::npos;
  EXPECT_EQ(columns, named ? 0 : 3) << j["not_built"].dump();
  EXPECT_TRUE(j["mismatches"].empty()) << j["mismatches"].dump();
#ifndef HBP_TEST_CUDA
  EXPECT_TRUE(named);
#endif
}

TEST_F(Cli, BenchPaperCarriesTheStoredGpuRunLabelled) {
  auto report = [&](const std::string& name, bool dry) {
    const std::string file = path(name);
    std::ofstream(file) << R"json({"dry_run": )json" << (dry ? "true" : "false")
                        << R"json(, "gpu": "Test GPU", "date": "2026-01-02T03:04:05Z", "host": "host: 16 CPUs",
      "paper_1024000": {"frame_ms": 0.5, "with_transfers_ms": 4.5, "lbvh_ms": 1.5, "energy_per_frame_j": 0.25,
                        "cpu_cells_gpu_accelerator_engine_ms": 40.0},
      "runs": [{"name": "paper-1000", "system": "frame", "kind": "paper", "order": "sorted by (a, b)",
                "objects": 1000, "median_frame_ms": 0.125, "exact": true},
               {"name": "paper-1000-cubes", "system": "frame", "kind": "paper", "order": "sorted by (a, b)",
                "objects": 1000, "median_frame_ms": 7.0, "exact": true},
               {"name": "paper-2000", "system": "frame", "kind": "paper", "order": "sorted by (a, b)",
                "objects": 2000, "median_frame_ms": 9.0, "exact": false}]})json";
    return file;
  };
  auto tables_of = [&](const std::string& gpu_report, const std::string& out) {
    const Result r = hbp({"bench", "paper", "--n", "1000,2000", "--frames", "1", "--warmup", "0", "--variants", "1",
                          "--systems", "sw", "--no-plots", "--gpu-report", gpu_report, "--out", path(out)});
    EXPECT_EQ(r.status, 0) << r.output;
    std::ifstream f(path(out) + "/tables.md");
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  };
  const std::string measured = tables_of(report("gpu.json", false), "measured");
  EXPECT_NE(measured.find("Measured on Test GPU (2026-01-02T03:04:05Z"), std::string::npos) << measured;
  EXPECT_NE(measured.find("| 1000 | 0.125"), std::string::npos) << "the defaults' run, not another option's:\n"
                                                                 << measured;
  EXPECT_EQ(measured.find("| 2000 | 9"), std::string::npos) << "an inexact run shown:\n" << measured;
  EXPECT_NE(measured.find("our GPU LBVH 1.500 ms"), std::string::npos) << measured;
  EXPECT_NE(measured.find("our GPU frame 0.5000 ms (4.500 ms with host transfers)"), std::string::npos) << measured;
  EXPECT_NE(measured.find("partition excluded) 40.000 ms"), std::string::npos) << measured;
  std::ifstream json_file(path("measured") + "/report.json");
  const std::string json((std::istreambuf_iterator<char>(json_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"gpu\": \"Test GPU\""), std::string::npos) << json;

  for (const std::string& missing : {path("none.json"), report("dry.json", true)}) {
    const std::string tables = tables_of(missing, "unmeasured");
    EXPECT_NE(tables.find("Our GPU frame: not measured (no GPU report at " + missing), std::string::npos) << tables;
    EXPECT_EQ(tables.find("Measured on"), std::string::npos) << tables;
  }
}

// The traces say what their columns and marks mean; bench paper's help says
// how long the default run takes.
TEST_F(Cli, TracesExplainTheirColumnsAndBenchHelpItsDuration) {
  const Result mo = hbp({"hw", "trace", "--design", "mo"});
  ASSERT_EQ(mo.status, 0) << mo.output;
  EXPECT_NE(mo.output.find("* comparator 0, \u2020 1, \u2021 2, \u00a7 3"), std::string::npos) << mo.output;
  const Result wide = hbp({"hw", "trace", "--design", "mo", "--m", "8", "--n", "20"});
  ASSERT_EQ(wide.status, 0) << wide.output;
  EXPECT_NE(wide.output.find("[c] comparator c"), std::string::npos) << wide.output;
  const Result ae = hbp({"hw", "trace", "--design", "ae"});
  ASSERT_EQ(ae.status, 0) << ae.output;
  EXPECT_NE(ae.output.find("anchor-partner"), std::string::npos) << ae.output;
  const Result help = hbp({"bench", "paper", "--help"});
  EXPECT_EQ(help.status, 0) << help.output;
  EXPECT_NE(help.output.find("an hour or more on 2 cores"), std::string::npos) << help.output;
}

// docs/cli.md's "JSON outputs" lists, per command, the keys at each place
// ("keys `.rows[]`: `a` `b` ..."); the real outputs have exactly those keys.
TEST_F(Cli, JsonOutputsHaveTheDocumentedKeys) {
  std::ifstream doc_file(std::string(HBP_SOURCE_DIR) + "/docs/cli.md");
  ASSERT_TRUE(doc_file) << "docs/cli.md";
  std::map<std::string, std::vector<std::pair<std::string, std::set<std::string>>>> documented;  // command -> places
  std::string line, command;
  while (std::getline(doc_file, line)) {
    if (line.rfind("- `hbp ", 0) == 0) command = line.substr(3, line.find('`', 3) - 3);
    const std::size_t at = line.find("- keys `");
    if (at == std::string::npos || command.empty()) continue;
    const std::size_t place_end = line.find('`', at + 8);
    std::set<std::string> keys;
    std::istringstream rest(line.substr(line.find(':', place_end) + 1));
    for (std::string word; rest >> word;) keys.insert(word.substr(1, word.size() - 2));
    documented[command].push_back({line.substr(at + 8, place_end - at - 8), keys});
  }
  const std::string bench_out = path("json-bench");
  std::map<std::string, std::vector<std::string>> runs = {
      {"hbp run --json", {"run", "--n", "3000", "--frames", "2", "--json", "--quiet"}},
      {"hbp hw asic --json", {"hw", "asic", "--json", "--reports", std::string(HBP_SOURCE_DIR) + "/docs/results/asic"}},
      {"hbp hw energy --json",
       {"hw", "energy", "--json", "--n", "3000", "--frames", "1", "--reports",
        std::string(HBP_SOURCE_DIR) + "/docs/results/asic"}},
      {"hbp hw run --json", {"hw", "run", "--json", "--n", "200"}},
      {"hbp hw explore --json", {"hw", "explore", "--json", "--n", "100", "--m", "4"}},
      {"hbp bench ... --out DIR",
       {"bench", "paper", "--n", "300", "--frames", "1", "--warmup", "0", "--variants", "1", "--systems", "sw",
        "--no-plots", "--out", bench_out}},
  };
#ifdef HBP_TEST_CUDA
  runs.insert({"hbp bench gpu --json",
               {"bench", "gpu", "--launcher", "host", "--n", "2000", "--frames", "2", "--threads", "2", "--json"}});
#else
  documented.erase("hbp bench gpu --json");  // this hbp has no CUDA room
#endif
  ASSERT_EQ(documented.size(), runs.size()) << "a documented command without a check, or the reverse";
  for (const auto& [name, args] : runs) {
    ASSERT_TRUE(documented.count(name)) << name << " not documented";
    const Result r = hbp(args);
    ASSERT_EQ(r.status, 0) << name << ":\n" << r.output;
    nlohmann::json j;
    if (name.rfind("hbp bench ... --out", 0) == 0) {
      std::ifstream report(bench_out + "/report.json");
      report >> j;
    } else {
      j = nlohmann::json::parse(r.output);
    }
    for (const auto& [place, keys] : documented.at(name)) {
      // ".", ".a", ".a[]", "[]": the object at that place (the first element of an array).
      const nlohmann::json* at = &j;
      std::string rest = place;
      if (rest.rfind(".", 0) == 0) rest.erase(0, 1);
      while (!rest.empty()) {
        if (rest.rfind("[]", 0) == 0) {
          ASSERT_TRUE(at->is_array() && !at->empty()) << name << " " << place;
          at = &(*at)[0];
          rest.erase(0, 2);
          continue;
        }
        const std::size_t end = rest.find_first_of(".[");
        const std::string key = rest.substr(0, end);
        ASSERT_TRUE(at->is_object() && at->contains(key)) << name << ": no " << key << " at " << place;
        at = &(*at)[key];
        rest.erase(0, end == std::string::npos ? rest.size() : end);
        if (rest.rfind(".", 0) == 0) rest.erase(0, 1);
      }
      ASSERT_TRUE(at->is_object()) << name << " " << place;
      std::set<std::string> actual;
      for (const auto& item : at->items()) actual.insert(item.key());
      EXPECT_EQ(actual, keys) << name << " at " << place;
    }
  }
}

}  // namespace
