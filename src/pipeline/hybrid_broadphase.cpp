#include "hbp/hybrid_broadphase.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "hbp/error.hpp"
#include "hbp/kd_partition.hpp"

namespace hbp {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// Cheap parallel screen; on failure the serial validate() names the object.
void validate_boxes(const BoxArray& boxes) {
  const bool bad = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, boxes.size(), 16384), false,
      [&](const auto& r, bool acc) {
        if (acc) return true;
        bool ok = true;
        for (int k = 0; k < 3; ++k) {
          const float* lo = boxes.min(k);
          const float* hi = boxes.max(k);
          for (std::size_t i = r.begin(); i != r.end(); ++i)
            ok &= std::isfinite(lo[i]) & std::isfinite(hi[i]) & (lo[i] <= hi[i]);
        }
        return !ok;
      },
      [](bool a, bool b) { return a || b; });
  if (bad) boxes.validate("frame");
}

struct Worker {
  std::unique_ptr<CellEngine> engine;
  BoxArray cell;
  std::vector<Pair> local;
};

}  // namespace

struct HybridBroadPhase::Impl {
  BroadPhaseOptions options;
  std::unique_ptr<CellEngine> prototype;
  std::uint32_t cell_limit;
  tbb::task_arena arena;
  KdPartition partition;
  tbb::enumerable_thread_specific<Worker> workers;
  std::vector<std::vector<Pair>> cell_pairs;
  std::vector<std::uint64_t> cell_cycles;
  std::vector<std::uint64_t> candidates;
  std::vector<std::size_t> offsets;
  std::vector<Pair> pairs;
  FrameStats stats;

  static std::uint32_t choose_limit(const BroadPhaseOptions& o, const CellEngine& e) {
    const std::uint32_t limit = o.cell_limit ? o.cell_limit : e.default_cell_limit();
    if (limit < 2) throw InvalidInput("cell limit must be >= 2 (got " + std::to_string(limit) + ")");
    return limit;
  }

  explicit Impl(const BroadPhaseOptions& o)
      : options(o),
        prototype(make_cell_engine(o.engine)),
        cell_limit(choose_limit(o, *prototype)),
        arena(o.threads ? static_cast<int>(o.threads) : tbb::task_arena::automatic),
        partition(cell_limit),
        workers([this] { return Worker{prototype->clone(), BoxArray{}, {}}; }) {}

  void gather(const std::uint32_t* entries, std::uint32_t count, BoxArray& dst, std::uint32_t at) {
    const BoxArray& src = partition.sorted_boxes();
    for (int l = 0; l < 3; ++l) {
      const float* smin = src.min(l);
      const float* smax = src.max(l);
      float* dmin = dst.min(l) + at;
      float* dmax = dst.max(l) + at;
      for (std::uint32_t i = 0; i < count; ++i) {
        dmin[i] = smin[entries[i]];
        dmax[i] = smax[entries[i]];
      }
    }
  }

  void process_cell(std::uint32_t c) {
    Worker& w = workers.local();
    const auto entries = partition.cell(c);
    const CellRegion& region = partition.region(c);
    const auto& ids = partition.sorted_ids();
    const auto n = static_cast<std::uint32_t>(entries.size());
    std::vector<Pair>& out = cell_pairs[c];
    out.clear();
    std::uint64_t cycles = 0;
    std::uint64_t found = 0;
    const std::uint32_t cap = w.engine->capacity();
    if (n <= cap) {
      w.cell.resize(n);
      gather(entries.data(), n, w.cell, 0);
      w.local.clear();
      cycles += w.engine->find_owned_pairs(w.cell, region, w.local).cycles;
      found = w.local.size();
      out.reserve(w.local.size());
      for (const Pair& p : w.local) out.push_back(make_pair(ids[entries[p.a]], ids[entries[p.b]]));
    } else {
      // More objects than the engine holds (identical or nested boxes): run
      // every pair of blocks of cap/2 through the engine. Block i's own pairs
      // are kept from the run (i, i+1); the last block's from (k-2, k-1).
      const std::uint32_t block = std::max<std::uint32_t>(1, cap / 2);
      const std::uint32_t k = (n + block - 1) / block;
      for (std::uint32_t bi = 0; bi < k; ++bi) {
        for (std::uint32_t bj = bi + 1; bj < k; ++bj) {
          const std::uint32_t oi = bi * block, ni = std::min(block, n - oi);
          const std::uint32_t oj = bj * block, nj = std::min(block, n - oj);
          w.cell.resize(ni + nj);
          gather(entries.data() + oi, ni, w.cell, 0);
          gather(entries.data() + oj, nj, w.cell, ni);
          w.local.clear();
          cycles += w.engine->find_owned_pairs(w.cell, region, w.local).cycles;
          const bool keep_i = bj == bi + 1;
          const bool keep_j = bi + 2 == k && bj + 1 == k;
          auto global = [&](std::uint32_t local) {
            return ids[entries[local < ni ? oi + local : oj + (local - ni)]];
          };
          for (const Pair& p : w.local) {
            const bool a_in_i = p.a < ni, b_in_i = p.b < ni;
            const bool keep = (a_in_i != b_in_i) || (a_in_i && keep_i) || (!a_in_i && keep_j);
            if (keep) out.push_back(make_pair(global(p.a), global(p.b)));
          }
          found += w.local.size();
        }
      }
    }
    cell_cycles[c] = cycles;
    candidates[c] = found;
  }

  void run(const BoxArray& boxes, const PairSink& sink) {
    const auto t0 = Clock::now();
    validate_boxes(boxes);
    partition.update(boxes);
    const double partition_ms = ms_since(t0);

    const auto t1 = Clock::now();
    const std::uint32_t cells = partition.cell_count();
    if (cell_pairs.size() < cells) cell_pairs.resize(cells);
    cell_cycles.assign(cells, 0);
    candidates.assign(cells, 0);
    if (sink) {
      // Consumer (narrow phase) on cell k while the engine works on k+1...
      std::uint32_t next = 0;
      const auto tokens = static_cast<std::size_t>(2 * std::max(1, arena.max_concurrency()));
      tbb::parallel_pipeline(
          tokens,
          tbb::make_filter<void, std::uint32_t>(tbb::filter_mode::serial_in_order,
                                                [&](tbb::flow_control& fc) -> std::uint32_t {
                                                  if (next >= cells) {
                                                    fc.stop();
                                                    return 0;
                                                  }
                                                  return next++;
                                                }) &
              tbb::make_filter<std::uint32_t, std::uint32_t>(tbb::filter_mode::parallel,
                                                             [&](std::uint32_t c) {
                                                               process_cell(c);
                                                               return c;
                                                             }) &
              tbb::make_filter<std::uint32_t, void>(tbb::filter_mode::serial_in_order, [&](std::uint32_t c) {
                sink(c, cell_pairs[c].data(), cell_pairs[c].size());
              }));
    } else {
      tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, cells, 1), [&](const auto& r) {
        for (std::uint32_t c = r.begin(); c != r.end(); ++c) process_cell(c);
      });
    }
    const double engine_ms = ms_since(t1);

    const auto t2 = Clock::now();
    offsets.assign(cells + 1, 0);
    std::uint64_t cycles = 0, cand = 0;
    for (std::uint32_t c = 0; c < cells; ++c) {
      offsets[c + 1] = offsets[c] + cell_pairs[c].size();
      cycles += cell_cycles[c];
      cand += candidates[c];
    }
    const std::size_t total = offsets[cells];
    if (options.max_pairs && total > options.max_pairs)
      throw CapacityExceeded("frame has " + std::to_string(total) + " overlapping pairs, above max_pairs = " +
                             std::to_string(options.max_pairs));
    pairs.resize(total);
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, cells, 16), [&](const auto& r) {
      for (std::uint32_t c = r.begin(); c != r.end(); ++c)
        std::copy(cell_pairs[c].begin(), cell_pairs[c].end(), pairs.begin() + static_cast<std::ptrdiff_t>(offsets[c]));
    });
    if (options.sorted) sort_pairs(pairs);
    const double merge_ms = ms_since(t2);

    const PartitionStats& ps = partition.stats();
    stats.pairs = total;
    stats.candidate_pairs = cand;
    stats.cells = ps.cells;
    stats.min_cell = ps.min_cell;
    stats.median_cell = ps.median_cell;
    stats.max_cell = ps.max_cell;
    stats.duplication = ps.duplication;
    stats.partition_ms = partition_ms;
    stats.engine_ms = engine_ms;
    stats.dedup_ms = merge_ms;
    stats.wall_ms = ms_since(t0);
    stats.modelled_cycles = cycles;
    const double hz = prototype->clock_hz();
    stats.modelled_ms = hz > 0 ? 1e3 * static_cast<double>(cycles) / hz : 0.0;
  }
};

HybridBroadPhase::HybridBroadPhase(const BroadPhaseOptions& options) : impl_(std::make_unique<Impl>(options)) {}
HybridBroadPhase::~HybridBroadPhase() = default;
HybridBroadPhase::HybridBroadPhase(HybridBroadPhase&&) noexcept = default;
HybridBroadPhase& HybridBroadPhase::operator=(HybridBroadPhase&&) noexcept = default;

const std::vector<Pair>& HybridBroadPhase::update(const BoxArray& boxes, const PairSink& sink) {
  impl_->arena.execute([&] { impl_->run(boxes, sink); });
  return impl_->pairs;
}
const std::vector<Pair>& HybridBroadPhase::pairs() const { return impl_->pairs; }
const FrameStats& HybridBroadPhase::stats() const { return impl_->stats; }
const BroadPhaseOptions& HybridBroadPhase::options() const { return impl_->options; }
std::uint32_t HybridBroadPhase::cell_limit() const { return impl_->cell_limit; }

}  // namespace hbp
