#include <time.h>
#include <cstdlib>
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
#include "partition/min_x_order.hpp"

namespace hbp {

namespace {

struct Clock { struct time_point { double ms; }; static time_point now() { timespec ts; clock_gettime(std::getenv("CPUCLK") ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC, &ts); return {ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6}; } };
double ms_since(Clock::time_point t) { return Clock::now().ms - t.ms; }

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
          // x - x == 0 exactly when x is finite; written so it vectorises.
          for (std::size_t i = r.begin(); i != r.end(); ++i)
            ok &= (lo[i] - lo[i] == 0.0f) & (hi[i] - hi[i] == 0.0f) & (lo[i] <= hi[i]);
        }
        return !ok;
      },
      [](bool a, bool b) { return a || b; });
  if (bad) boxes.validate("frame");
}

struct Worker {
  std::unique_ptr<CellEngine> engine;
  BoxArray cell;                        // the cell's boxes in min-x order
  std::vector<Pair> local;              // the engine's pairs (local indices)
  std::vector<std::uint32_t> order;     // min-x order of the cell's entries
  std::vector<std::uint64_t> sort_scratch;
  std::vector<float> min_x;
};

}  // namespace

struct HybridBroadPhase::Impl {
  BroadPhaseOptions options;
  std::unique_ptr<CellEngine> prototype;
  std::uint32_t cell_limit;
  tbb::task_arena arena;
  KdPartition own_partition;
  const KdPartition* partition = &own_partition;  // this frame's cells
  tbb::enumerable_thread_specific<Worker> workers;
  std::vector<std::vector<Pair>> cell_pairs;
  std::vector<std::uint64_t> cell_cycles;
  std::vector<std::uint64_t> candidates;
  std::vector<std::size_t> offsets;
  std::vector<Pair> pairs;
  FrameStats stats;
  std::atomic<std::uint64_t> running_pairs{0};

  static std::uint32_t choose_limit(const BroadPhaseOptions& o, const CellEngine& e) {
    const std::uint32_t limit = o.cell_limit ? o.cell_limit : e.default_cell_limit();
    if (limit < 2) throw InvalidInput("cell limit must be >= 2 (got " + std::to_string(limit) + ")");
    return limit;
  }

  static KdPartition::CellCost cell_cost(const BroadPhaseOptions& o, const CellEngine& e) {
    if (!o.cost_splits || e.clock_hz() <= 0) return {};
    // The cells of a frame run one after another: their cycles add up.
    std::shared_ptr<const CellEngine> engine = e.clone();
    return [engine](std::uint32_t n) { return static_cast<double>(engine->cycles_for(n)); };
  }

  explicit Impl(const BroadPhaseOptions& o)
      : options(o),
        prototype(make_cell_engine(o.engine)),
        cell_limit(choose_limit(o, *prototype)),
        arena(o.threads ? static_cast<int>(o.threads) : tbb::task_arena::automatic),
        own_partition(cell_limit, prototype->x_split_weight(), cell_cost(o, *prototype)),
        workers([this] {
          Worker w{prototype->clone(), BoxArray{}, {}, {}, {}, {}};
          if (options.max_pairs) w.engine->set_pair_limit(options.max_pairs);
          return w;
        }) {}

  void charge(std::size_t pairs_added) {
    if (!options.max_pairs) return;
    const std::uint64_t total = running_pairs.fetch_add(pairs_added) + pairs_added;
    if (total > options.max_pairs)
      throw CapacityExceeded("frame has more than max_pairs = " + std::to_string(options.max_pairs) +
                             " overlapping pairs (stopped at " + std::to_string(total) + ")");
  }

  // Copies entries [first, first + count) of the cell, in min-x order, to
  // dst starting at `at`.
  static void gather(const Worker& w, const CellEntry* cell, std::uint32_t first, std::uint32_t count, BoxArray& dst,
                     std::uint32_t at) {
    const std::uint32_t* order = w.order.data() + first;
    float* d[6] = {dst.min(0) + at, dst.min(1) + at, dst.min(2) + at, dst.max(0) + at, dst.max(1) + at, dst.max(2) + at};
    for (std::uint32_t i = 0; i < count; ++i) {
      const CellEntry& e = cell[order[i]];
      d[0][i] = e.min[0];
      d[1][i] = e.min[1];
      d[2][i] = e.min[2];
      d[3][i] = e.max[0];
      d[4][i] = e.max[1];
      d[5][i] = e.max[2];
    }
  }

  void process_cell(std::uint32_t c) {
    Worker& w = workers.local();
    const CellEntry* cell = partition->cell(c).data();
    const std::uint32_t n = partition->cell_size(c);
    const CellRegion& region = partition->region(c);
    w.min_x.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) w.min_x[i] = cell[i].min[0];
    min_x_order(w.min_x.data(), n, w.order, w.sort_scratch);
    std::vector<Pair>& out = cell_pairs[c];
    out.clear();
    std::uint64_t cycles = 0;
    std::uint64_t found = 0;
    const std::uint32_t cap = w.engine->capacity();
    if (n <= cap) {
      w.cell.resize(n);
      gather(w, cell, 0, n, w.cell, 0);
      w.local.clear();
      cycles += w.engine->find_owned_pairs(w.cell, region, w.local).cycles;
      found = w.local.size();
      charge(found);
      out.resize(w.local.size());
      for (std::size_t i = 0; i < w.local.size(); ++i)
        out[i] = make_pair(cell[w.order[w.local[i].a]].id, cell[w.order[w.local[i].b]].id);
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
          gather(w, cell, oi, ni, w.cell, 0);
          gather(w, cell, oj, nj, w.cell, ni);
          w.local.clear();
          cycles += w.engine->find_owned_pairs(w.cell, region, w.local).cycles;
          const std::size_t before = out.size();
          const bool keep_i = bj == bi + 1;
          const bool keep_j = bi + 2 == k && bj + 1 == k;
          auto global = [&](std::uint32_t local) { return cell[w.order[local < ni ? oi + local : oj + (local - ni)]].id; };
          for (const Pair& p : w.local) {
            const bool a_in_i = p.a < ni, b_in_i = p.b < ni;
            const bool keep = (a_in_i != b_in_i) || (a_in_i && keep_i) || (!a_in_i && keep_j);
            if (keep) out.push_back(make_pair(global(p.a), global(p.b)));
          }
          charge(out.size() - before);
          found += w.local.size();
        }
      }
    }
    cell_cycles[c] = cycles;
    candidates[c] = found;
  }

  void run(const BoxArray* boxes, const KdPartition* shared, const PairSink& sink, const PairSink& consumer) {
    running_pairs = 0;
    const auto t0 = Clock::now();
    if (shared) {
      partition = shared;  // cells maintained elsewhere (the ray tracer's hierarchy)
    } else {
      partition = &own_partition;
      validate_boxes(*boxes);
      own_partition.update(*boxes);
    }
    const double partition_ms = ms_since(t0);

    const auto t1 = Clock::now();
    const std::uint32_t cells = partition->cell_count();
    if (cell_pairs.size() < cells) cell_pairs.resize(cells);
    cell_cycles.assign(cells, 0);
    candidates.assign(cells, 0);
    auto cell_task = [&](std::uint32_t c) {
      process_cell(c);
      if (consumer) consumer(c, cell_pairs[c].data(), cell_pairs[c].size());
    };
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
                                                               cell_task(c);
                                                               return c;
                                                             }) &
              tbb::make_filter<std::uint32_t, void>(tbb::filter_mode::serial_in_order, [&](std::uint32_t c) {
                sink(c, cell_pairs[c].data(), cell_pairs[c].size());
              }));
    } else {
      tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, cells, 1), [&](const auto& r) {
        for (std::uint32_t c = r.begin(); c != r.end(); ++c) cell_task(c);
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

    const PartitionStats& ps = partition->stats();
    stats.pairs = total;
    stats.candidate_pairs = cand;
    stats.cells = ps.cells;
    stats.min_cell = ps.min_cell;
    stats.median_cell = ps.median_cell;
    stats.max_cell = ps.max_cell;
    stats.duplication = ps.duplication;
    stats.oversized_cells = ps.oversized_cells;
    stats.rebuilt = ps.rebuilt;
    stats.splits = ps.splits;
    stats.merges = ps.merges;
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

const std::vector<Pair>& HybridBroadPhase::update(const BoxArray& boxes, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->arena.execute([&] { impl_->run(&boxes, nullptr, sink, parallel_consumer); });
  return impl_->pairs;
}

const std::vector<Pair>& HybridBroadPhase::update(const KdPartition& cells, const PairSink& sink,
                                                  const PairSink& parallel_consumer) {
  impl_->arena.execute([&] { impl_->run(nullptr, &cells, sink, parallel_consumer); });
  return impl_->pairs;
}
const std::vector<Pair>& HybridBroadPhase::pairs() const { return impl_->pairs; }
const FrameStats& HybridBroadPhase::stats() const { return impl_->stats; }
const BroadPhaseOptions& HybridBroadPhase::options() const { return impl_->options; }
std::uint32_t HybridBroadPhase::cell_limit() const { return impl_->cell_limit; }

}  // namespace hbp
