// SPDX-License-Identifier: MIT
// `hbp pairs`: the overlapping pairs of one frame of a scene file, as sorted
// lines "a b" (a < b), from the oracle or from the hybrid system. Two runs
// with different engines or formats can be compared with `cmp` or `diff`.
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cmd_distributed.hpp"
#include "command_registry.hpp"
#include "option_checks.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scene_file.hpp"
#include "support/clock.hpp"

namespace hbp::cli {

namespace {

struct PairsOptions {
  std::string file;
  std::uint32_t frame = 0;
  std::string engine = "brute";
  std::uint32_t cell_limit = 0;
  unsigned threads = 0;
  std::string out;  // empty: stdout
  bool distributed = false;
};

// Writes "a b\n" lines through a large buffer: tens of millions of pairs are
// normal for big paper scenes, and printf per line would dominate.
void write_pairs(const std::vector<Pair>& pairs, std::FILE* out, const std::string& where) {
  constexpr std::size_t kBufferBytes = 1 << 20;
  constexpr std::size_t kLineMax = 2 * 10 + 2;  // two uint32 + space + newline
  std::vector<char> buffer(kBufferBytes);
  std::size_t used = 0;
  auto flush = [&] {
    if (used != 0 && std::fwrite(buffer.data(), 1, used, out) != used)
      throw FileError(where + ": write failed: " + std::strerror(errno));
    used = 0;
  };
  for (const Pair& p : pairs) {
    if (used + kLineMax > buffer.size()) flush();
    char* at = buffer.data() + used;
    char* end = buffer.data() + buffer.size();
    at = std::to_chars(at, end, p.a).ptr;
    *at++ = ' ';
    at = std::to_chars(at, end, p.b).ptr;
    *at++ = '\n';
    used = static_cast<std::size_t>(at - buffer.data());
  }
  flush();
  if (std::fflush(out) != 0) throw FileError(where + ": write failed: " + std::strerror(errno));
}

void run_pairs(const PairsOptions& o) {
  SceneReader reader(o.file);
  if (reader.info().frame_count == 0) throw InvalidInput(o.file + ": the scene has no frames: no pairs to find");
  BoxArray boxes;
  reader.read_frame(o.frame, boxes);  // validates; names file, frame, object

  const auto start = SteadyClock::now();
  std::vector<Pair> pairs;
  if (o.distributed) {  // over MPI ranks; rank 0 gathers and writes
    if (!distributed_pairs(boxes, o.engine, o.cell_limit, o.threads, pairs)) return;
  } else if (o.engine == "brute") {
    pairs = brute_force_pairs(boxes);  // the oracle: already sorted and canonical
  } else {
    BroadPhaseOptions options;
    options.engine = o.engine;
    options.cell_limit = o.cell_limit;
    options.threads = o.threads;
    options.sorted = true;
    HybridBroadPhase broadphase(options);
    pairs = broadphase.update(boxes);
  }
  const double ms = ms_since(start);
  // The output promises sorted canonical pairs whatever the engine did.
  if (!std::is_sorted(pairs.begin(), pairs.end())) sort_pairs(pairs);

  if (o.out.empty()) {
    write_pairs(pairs, stdout, "stdout");
  } else {
    std::FILE* f = std::fopen(o.out.c_str(), "wb");
    if (f == nullptr) throw FileError(o.out + ": cannot create: " + std::strerror(errno));
    try {
      write_pairs(pairs, f, o.out);
    } catch (...) {
      std::fclose(f);
      throw;
    }
    if (std::fclose(f) != 0) throw FileError(o.out + ": close failed: " + std::strerror(errno));
  }
  std::fprintf(stderr, "%zu pairs in frame %u of %s (%u objects, engine %s, %.1f ms)\n", pairs.size(), o.frame,
               o.file.c_str(), reader.info().object_count, o.engine.c_str(), ms);
}

void setup_pairs(CLI::App& app) {
  auto opts = std::make_shared<PairsOptions>();
  CLI::App* cmd = app.add_subcommand(
      "pairs", "Print the overlapping pairs of one frame of a scene file as sorted lines \"a b\" (count on stderr)");
  cmd->add_option("file", opts->file, "Scene file (native or Broadmark)")->required();
  cmd->add_option("--frame", opts->frame, "Frame index (Broadmark: 0 is the initial state)")->capture_default_str();
  cmd->add_option("--engine", opts->engine,
                  "brute (the oracle), or a cell engine run through the hybrid system: sw, ae, mo, ...")
      ->capture_default_str();
  cmd->add_option("--cell-limit", opts->cell_limit, "Most objects per k-d cell (0: the engine's default)")
      ->capture_default_str();
  cmd->add_option("--threads", opts->threads, "Worker threads of the hybrid system (0: all cores)")
      ->check(threads_range())
      ->capture_default_str();
  cmd->add_option("-o,--out", opts->out, "Write the pairs to this file instead of stdout");
  cmd->add_flag("--distributed", opts->distributed,
                "Over MPI ranks (start under mpirun); the engine runs on each rank, rank 0 writes");
  cmd->callback([opts] { run_pairs(*opts); });
}

const RegisterCommand registered{setup_pairs};

}  // namespace

}  // namespace hbp::cli
