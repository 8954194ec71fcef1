// SPDX-License-Identifier: MIT
// The distributed commands behind `--distributed` (cmd_run.cpp, cmd_pairs.cpp).
#include "cmd_distributed.hpp"

#include "hbp/error.hpp"

#if HBP_HAVE_MPI
#include <mpi.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <thread>

#include "hbp/distributed_broadphase.hpp"
#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"
#include "hbp/software_engine.hpp"
#include "support/percentile.hpp"
#endif

namespace hbp::cli {

#if !HBP_HAVE_MPI

void run_distributed(const RunRequest&) {
  throw InvalidInput("--distributed: this hbp was built without MPI (install libopenmpi-dev, see "
                     "scripts/install-deps, and rebuild)");
}
bool distributed_pairs(const BoxArray&, const std::string&, std::uint32_t, unsigned, std::vector<Pair>&) {
  run_distributed({});
  return false;
}

#else

namespace {

// MPI for the duration of one command (MPI_Init when mpirun did not start us
// gives a single rank).
class MpiSession {
 public:
  MpiSession() {
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
      int provided = 0;
      MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);  // only the main thread calls MPI
      owner_ = true;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiSession() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (owner_ && !finalized) MPI_Finalize();
  }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  bool owner_ = false;
  int rank_ = 0, size_ = 1;
};

// Ids [r * n / P, (r + 1) * n / P): who supplies what on the first frame.
std::vector<std::uint32_t> id_block(std::size_t n, int rank, int size) {
  const std::size_t lo = n * static_cast<std::size_t>(rank) / static_cast<std::size_t>(size);
  const std::size_t hi = n * static_cast<std::size_t>(rank + 1) / static_cast<std::size_t>(size);
  std::vector<std::uint32_t> ids(hi - lo);
  for (std::size_t i = lo; i < hi; ++i) ids[i - lo] = static_cast<std::uint32_t>(i);
  return ids;
}

DistributedOptions options_for(const std::string& engine, std::uint32_t cell_limit, unsigned threads) {
  DistributedOptions o;
  o.local.engine = engine;
  o.local.cell_limit = cell_limit;
  o.local.threads = threads;
  return o;
}

static_assert(std::is_trivially_copyable_v<FrameStats>, "FrameStats is gathered as bytes");

}  // namespace

bool distributed_pairs(const BoxArray& frame, const std::string& engine, std::uint32_t cell_limit, unsigned threads,
                       std::vector<Pair>& out) {
  MpiSession mpi;
  DistributedBroadPhase bp(MPI_COMM_WORLD, options_for(engine, cell_limit, threads));
  const std::vector<std::uint32_t> ids = id_block(frame.size(), mpi.rank(), mpi.size());
  BoxArray mine(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) mine.set(i, frame.get(ids[i]));
  bp.update(ids, mine);
  out = gather_pairs(MPI_COMM_WORLD, bp.pairs(), 0);
  return mpi.rank() == 0;
}

void run_distributed(const RunRequest& a) {
  MpiSession mpi;
  const int rank = mpi.rank(), size = mpi.size();
  std::unique_ptr<tbb::global_control> limit;
  if (a.threads) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);
  // Every rank holds the scene's description (scenario or file); each
  // computes only the boxes of the objects it supplies.
  std::unique_ptr<Scenario> scenario;
  std::unique_ptr<SceneReader> reader;
  std::uint32_t frames = a.frames;
  std::size_t objects = 0;
  if (!a.in.empty()) {
    reader = std::make_unique<SceneReader>(a.in);
    frames = std::min<std::uint32_t>(frames, reader->info().frame_count);
    objects = reader->info().object_count;
  } else {
    scenario = std::make_unique<Scenario>(scenario_params(a));
    objects = scenario->size();
  }
  DistributedBroadPhase bp(MPI_COMM_WORLD, options_for(a.engine, a.cell_limit, a.threads));
  std::vector<std::uint32_t> ids = id_block(objects, rank, size);
  BoxArray all, mine;
  nlohmann::json frames_json = nlohmann::json::array();
  std::vector<double> wall, modelled;
  double worst_imbalance = 0, worst_traffic = 0, worst_ghost_fraction = 0;
  const unsigned threads = a.threads ? a.threads : std::max(1u, std::thread::hardware_concurrency());
  if (rank == 0 && !a.json && !a.quiet) {
    std::printf("distributed over %d ranks: engine %s (simd %s), %zu objects, %u frames\n", size, a.engine.c_str(),
                SoftwareEngine::isa(), objects, frames);
    std::printf("%6s %10s %9s %9s %9s %9s %10s %9s %9s %s\n", "frame", "pairs", "wall_ms", "owned_min", "owned_max",
                "ghosts", "sent", "bytes", "imbalance", "domains");
  }
  for (std::uint32_t k = 0; k < frames; ++k) {
    mine.resize(ids.size());
    if (reader) {
      reader->read_frame(k, all);
      for (std::size_t i = 0; i < ids.size(); ++i) mine.set(i, all.get(ids[i]));
    } else {
      if (k > 0) scenario->step();  // the motion of every object: replicated, not timed
      for (std::size_t i = 0; i < ids.size(); ++i) mine.set(i, tight_aabb(scenario->shapes()[ids[i]]));
    }
    bp.update(ids, mine);
    ids = bp.owned_ids();  // next frame we supply what we own now
    const std::vector<RankFrameStats> ranks = bp.gather_stats(0);
    std::vector<FrameStats> locals(rank == 0 ? static_cast<std::size_t>(size) : 0);
    MPI_Gather(&bp.local_stats(), sizeof(FrameStats), MPI_BYTE, locals.data(), sizeof(FrameStats), MPI_BYTE, 0,
               MPI_COMM_WORLD);
    if (rank != 0) continue;
    // Frame figures: counts summed, times the slowest rank (the frame ends
    // when the last rank does).
    std::uint64_t pairs = 0, owned = 0, ghosts = 0, sent = 0, bytes = 0, owned_max = 0, owned_min = UINT64_MAX;
    double wall_ms = 0, modelled_ms = 0;
    bool rebalanced = false;
    nlohmann::json per_rank = nlohmann::json::array();
    for (int r = 0; r < size; ++r) {
      const RankFrameStats& s = ranks[static_cast<std::size_t>(r)];
      pairs += s.pairs, owned += s.owned, ghosts += s.ghosts, sent += s.ghosts_sent, bytes += s.bytes_sent;
      owned_max = std::max(owned_max, s.owned), owned_min = std::min(owned_min, s.owned);
      wall_ms = std::max(wall_ms, s.wall_ms);
      modelled_ms = std::max(modelled_ms, locals[static_cast<std::size_t>(r)].modelled_ms);
      rebalanced |= s.rebalanced != 0;
      per_rank.push_back({{"rank", r},
                          {"owned", s.owned},
                          {"ghosts", s.ghosts},
                          {"pairs", s.pairs},
                          {"local_pairs", s.local_pairs},
                          {"migrated_out", s.migrated_out},
                          {"ghosts_sent", s.ghosts_sent},
                          {"ghosts_added", s.ghosts_added},
                          {"ghosts_removed", s.ghosts_removed},
                          {"bytes_sent", s.bytes_sent},
                          {"decompose_ms", s.decompose_ms},
                          {"migrate_ms", s.migrate_ms},
                          {"ghost_ms", s.ghost_ms},
                          {"local_ms", s.local_ms},
                          {"filter_ms", s.filter_ms},
                          {"wall_ms", s.wall_ms}});
    }
    const double mean = static_cast<double>(owned) / size;
    double imbalance = 0;
    for (const RankFrameStats& s : ranks)
      if (mean > 0) imbalance = std::max(imbalance, std::abs(static_cast<double>(s.owned) - mean) / mean);
    const double traffic = owned ? static_cast<double>(sent) / static_cast<double>(owned) : 0;
    const double ghost_fraction = owned ? static_cast<double>(ghosts) / static_cast<double>(owned) : 0;
    worst_imbalance = std::max(worst_imbalance, imbalance);
    worst_traffic = std::max(worst_traffic, traffic);
    worst_ghost_fraction = std::max(worst_ghost_fraction, ghost_fraction);
    wall.push_back(wall_ms);
    const bool modelled_engine = modelled_ms > 0 || a.engine.rfind("ae", 0) == 0 || a.engine.rfind("mo", 0) == 0 ||
                                 a.engine.rfind("rtl", 0) == 0;
    if (modelled_engine) modelled.push_back(modelled_ms);
    // The `hbp run` frame fields, over all ranks.
    double partition_ms = 0, engine_ms = 0, dedup_ms = 0, entries = 0, local_objects = 0;
    std::uint64_t cells = 0, splits = 0, merges = 0;
    std::uint32_t median_cell = 0, max_cell = 0;
    bool rebuilt = false;
    for (int r = 0; r < size; ++r) {
      const FrameStats& f = locals[static_cast<std::size_t>(r)];
      const RankFrameStats& s = ranks[static_cast<std::size_t>(r)];
      partition_ms = std::max(partition_ms, f.partition_ms), engine_ms = std::max(engine_ms, f.engine_ms);
      dedup_ms = std::max(dedup_ms, f.after_engines_ms());  // the key hbp run prints: merge + sort
      cells += f.cells, splits += f.splits, merges += f.merges;
      median_cell = std::max(median_cell, f.median_cell), max_cell = std::max(max_cell, f.max_cell);
      rebuilt |= f.rebuilt;
      const double n_local = static_cast<double>(s.owned + s.ghosts);
      entries += f.duplication * n_local, local_objects += n_local;
    }
    frames_json.push_back({{"frame", k},
                           {"pairs", pairs},
                           {"wall_ms", wall_ms},
                           {"partition_ms", partition_ms},
                           {"engine_ms", engine_ms},
                           {"dedup_ms", dedup_ms},
                           {"cells", cells},
                           {"median_cell", median_cell},
                           {"max_cell", max_cell},
                           {"rebuilt", rebuilt},
                           {"splits", splits},
                           {"merges", merges},
                           {"duplication", local_objects > 0 ? entries / local_objects : 1.0},
                           {"modelled_ms", modelled_engine ? nlohmann::json(modelled_ms) : nlohmann::json(nullptr)},
                           {"rebalanced", rebalanced},
                           {"imbalance", imbalance},
                           {"ghosts", ghosts},
                           {"ghosts_sent", sent},
                           {"ghost_traffic", traffic},
                           {"bytes_sent", bytes},
                           {"ranks", per_rank}});
    if (!a.json && !a.quiet)
      std::printf("%6u %10llu %9.3f %9llu %9llu %9llu %10llu %9llu %9.4f %s\n", k,
                  static_cast<unsigned long long>(pairs), wall_ms, static_cast<unsigned long long>(owned_min),
                  static_cast<unsigned long long>(owned_max), static_cast<unsigned long long>(ghosts),
                  static_cast<unsigned long long>(sent), static_cast<unsigned long long>(bytes), imbalance,
                  rebalanced ? "rebalanced" : "kept");
  }
  if (rank != 0) return;
  const double med = percentile(wall, 0.5), p95 = percentile(wall, 0.95);
  if (a.json) {
    nlohmann::json params = {{"scene", a.in.empty() ? a.scene : std::string("file")},
                             {"in", a.in},
                             {"n", objects},
                             {"frames", frames},
                             {"seed", a.seed},
                             {"engine", a.engine},
                             {"cell_limit", a.cell_limit},
                             {"threads", threads},
                             {"cost_splits", false},
                             {"simd", SoftwareEngine::isa()},
                             {"distributed", true},
                             {"ranks", size},
                             {"rebalance_threshold", DistributedOptions{}.rebalance_threshold}};
    nlohmann::json summary = {
        {"median_wall_ms", med},
        {"p95_wall_ms", p95},
        {"median_modelled_ms", modelled.empty() ? nlohmann::json(nullptr) : nlohmann::json(percentile(modelled, 0.5))},
        {"max_imbalance", worst_imbalance},
        {"max_ghost_traffic", worst_traffic},
        {"max_ghost_fraction", worst_ghost_fraction}};
    std::printf("%s\n",
                nlohmann::json{{"params", params}, {"frames", frames_json}, {"summary", summary}}.dump(1).c_str());
  } else {
    std::printf("summary: wall (measured, slowest rank) median %.3f ms, p95 %.3f ms; owned imbalance max %.4f; "
                "ghost traffic max %.4f of owned per frame; ghosts held max %.4f of owned\n",
                med, p95, worst_imbalance, worst_traffic, worst_ghost_fraction);
  }
}

#endif

}  // namespace hbp::cli
