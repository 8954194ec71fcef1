// SPDX-License-Identifier: MIT
#include "bench_runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>

#include "bench_memory.hpp"
#include "duration_text.hpp"
#include "hbp/error.hpp"
#include "support/clock.hpp"
#include "support/percentile.hpp"

namespace hbp::cli {
namespace {


// Growth of a frame's cost with n when only one earlier row is known.
double default_frame_exponent(const std::string& key) { return key == "brute" ? 2.0 : 1.3; }
// bt32BitAxisSweep3::createProxy walks the sorted edge lists: quadratic.
double setup_exponent(const std::string& key) { return key == "bullet-axis-sweep" ? 2.0 : 1.2; }

}  // namespace

BenchRunner::BenchRunner(const BenchConfig& config, Progress progress, Log log)
    : config_(config), progress_(std::move(progress)), log_(std::move(log)) {
  systems_ = make_bench_systems(config_.choice, result_.missing);
  auto check_key = [](const std::string& k) {
    const auto known = bench_system_keys();
    if (std::find(known.begin(), known.end(), k) != known.end()) return;
    std::string list;
    for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
    throw InvalidInput("unknown bench system '" + k + "' (known: " + list + ")");
  };
  for (const auto& [k, secs] : config_.budget_for) check_key(k);
  if (!config_.only.empty()) {
    for (const auto& k : config_.only) check_key(k);
    std::erase_if(systems_, [&](const auto& s) {
      return std::find(config_.only.begin(), config_.only.end(), s->key()) == config_.only.end();
    });
  }
  if (systems_.empty()) throw InvalidInput("no bench system left to run");
  for (const auto& s : systems_) {
    result_.keys.push_back(s->key());
    result_.labels.push_back(s->label());
    result_.modelled.push_back(s->modelled());
  }
  history_.resize(systems_.size());
}

BenchRunner::~BenchRunner() = default;

void BenchRunner::plan(const std::vector<std::uint32_t>& object_counts) {
  for (std::uint32_t n : object_counts)
    work_total_ += static_cast<double>(n) * config_.variants * (config_.warmup + config_.frames + 1);
}

BenchRunner::Projection BenchRunner::project(std::size_t i, std::uint32_t n) const {
  Projection p;
  const auto& h = history_[i];
  if (h.empty()) return p;  // nothing known: run it (the in-row guard still applies)
  const History& last = h.back();
  // Growth exponent of a frame's time with n, fitted on the last two rows
  // (separately for wall time, which sets the budget, and for the reported
  // clock, which the table shows).
  auto exponent = [&](double History::*ms) {
    double e = default_frame_exponent(systems_[i]->key());
    if (h.size() >= 2) {
      const History& prev = h[h.size() - 2];
      if (last.n > prev.n && prev.*ms > 0 && last.*ms > 0)
        e = std::clamp(std::log(last.*ms / prev.*ms) / std::log(double(last.n) / prev.n), 1.0, 2.2);
    }
    return e;
  };
  const double r = static_cast<double>(n) / last.n;
  p.frame_wall_ms = last.frame_wall_ms * std::pow(r, exponent(&History::frame_wall_ms));
  p.frame_reported_ms = last.frame_reported_ms * std::pow(r, exponent(&History::frame_reported_ms));
  p.setup_s = last.setup_s * std::pow(r, setup_exponent(systems_[i]->key()));
  p.row_seconds = config_.variants * (p.setup_s + (config_.warmup + config_.frames) * p.frame_wall_ms * 1e-3);
  return p;
}

void BenchRunner::run_row(FrameSource& source) {
  const std::uint32_t n = source.object_count();
  const std::size_t count = systems_.size();
  RowResult row;
  row.n = n;
  row.cells.resize(count);

  // Who takes part in this row.
  std::vector<bool> active(count, false);
  for (std::size_t i = 0; i < count; ++i) {
    CellResult& c = row.cells[i];
    BenchSystem& s = *systems_[i];
    if (!s.applies(n)) {
      c.status = CellStatus::NotApplicable;
      c.note = s.not_applicable_reason(n);
      continue;
    }
    // Our software hybrid is the reference every other system is checked
    // against: it always runs.
    const Projection projected = project(i, n);
    if (s.key() != "sw" && projected.row_seconds > config_.budget_of(s.key())) {
      c.status = CellStatus::Projected;
      c.projected_ms = projected.frame_reported_ms;
      c.projected_setup_s = projected.setup_s;
      c.note = "projected, row would take " + format_duration(projected.row_seconds);
      continue;
    }
    c.status = CellStatus::Ran;
    active[i] = true;
  }
  // The reference every other system is checked against: our software
  // hybrid when it runs, else the first system that does.
  std::size_t ref = count;
  for (std::size_t i = 0; i < count; ++i)
    if (active[i] && systems_[i]->key() == "sw") ref = i;
  if (ref == count)
    for (std::size_t i = 0; i < count && ref == count; ++i)
      if (active[i]) ref = i;

  std::vector<std::vector<double>> reported(count), wall(count), cpu(count);
  std::vector<std::vector<double>> raw(count);
  std::vector<double> spent(count, 0), setup(count, 0);
  std::vector<MemoryMeter> memory(count);
  std::vector<std::uint64_t> peak_bytes(count, 0);
  std::vector<bool> memory_ok(count, true);
  std::vector<double> ref_pairs;
  BoxArray boxes;

  auto fail = [&](std::size_t i, const std::string& what, const std::exception& e) {
    active[i] = false;
    row.cells[i].status = CellStatus::Failed;
    row.cells[i].note = what + ": " + e.what();
    log_("FAILED n=" + std::to_string(n) + " " + systems_[i]->key() + " " + row.cells[i].note);
  };
  auto tick = [&](const std::string& what) {
    work_done_ += n;
    if (progress_) progress_(work_done_, work_total_, what);
  };
  // Stops a system whose time in this row runs far past the budget (the
  // projection had no earlier row, or was wrong).
  auto over_budget = [&](std::size_t i) {
    if (i == ref) return false;  // the reference runs every frame, whatever it costs
    const double budget = config_.budget_of(systems_[i]->key());
    if (spent[i] <= 2 * budget) return false;
    active[i] = false;
    row.cells[i].note = "stopped at " + format_duration(spent[i]) + " (budget " + format_duration(budget) +
                        ") after " + std::to_string(reported[i].size()) + " frames";
    log_("n=" + std::to_string(n) + " " + systems_[i]->key() + ": " + row.cells[i].note);
    return true;
  };

  const std::string row_name = "n=" + std::to_string(n);
  for (std::uint32_t v = 0; v < config_.variants; ++v) {
    source.begin_variant(v, boxes);
    for (std::size_t i = 0; i < count; ++i) {
      if (!active[i]) continue;
      // A fresh meter per world: the system's earlier world is freed by
      // setup(), the heap trimmed so freed pages are not silently reused.
      if (v > 0) peak_bytes[i] = std::max(peak_bytes[i], memory[i].peak_bytes());
      memory[i].reset();
      trim_heap();
      memory[i].before();
      const auto t0 = SteadyClock::now();
      try {
        systems_[i]->setup(boxes);
      } catch (const std::exception& e) {
        fail(i, "setup", e);
      }
      const double s = seconds_since(t0);
      memory[i].after();
      setup[i] += s;
      spent[i] += s;
    }
    tick(row_name + " v" + std::to_string(v) + " setup");
    const std::uint32_t total_frames = config_.warmup + config_.frames;
    for (std::uint32_t f = 0; f < total_frames; ++f) {
      source.next(boxes);
      const bool timed = f >= config_.warmup;
      const std::uint32_t frame = f + 1;  // frame 0 was the setup frame
      // Reference first, so the others can be compared with it.
      std::vector<std::size_t> order;
      if (ref < count && active[ref]) order.push_back(ref);
      for (std::size_t i = 0; i < count; ++i)
        if (i != ref && active[i]) order.push_back(i);
      const std::vector<Pair>* expected = nullptr;
      for (std::size_t i : order) {
        if (over_budget(i)) continue;
        FrameTime t;
        memory[i].before();
        try {
          t = systems_[i]->update(boxes);
        } catch (const std::exception& e) {
          memory[i].after();
          fail(i, "frame " + std::to_string(frame), e);
          continue;
        }
        memory[i].after();
        spent[i] += t.wall_ms * 1e-3;
        if (!timed) continue;
        const std::vector<Pair>& got = systems_[i]->exact_pairs();
        bool match = true;
        if (i == ref) {
          expected = &got;
          ref_pairs.push_back(static_cast<double>(got.size()));
        } else if (expected) {
          const PairSetDiff d = diff_pairs(*expected, got);
          if (!d.empty()) {
            match = false;
            ++row.cells[i].mismatched_frames;
            Mismatch m{n, v, frame, systems_[i]->key(), systems_[ref]->key(), d.summary()};
            log_("MISMATCH n=" + std::to_string(n) + " variant " + std::to_string(v) + " frame " +
                 std::to_string(frame) + ": " + m.system + " vs " + m.reference + ": " + m.summary);
            result_.mismatches.push_back(std::move(m));
          }
        }
        reported[i].push_back(t.reported_ms);
        wall[i].push_back(t.wall_ms);
        cpu[i].push_back(t.cpu_ms);
        raw[i].push_back(static_cast<double>(systems_[i]->raw_pairs()));
        result_.samples.push_back({n, v, frame, static_cast<std::uint32_t>(i), t.reported_ms, t.wall_ms,
                                   t.cpu_ms, systems_[i]->raw_pairs(), static_cast<std::uint64_t>(got.size()), match});
      }
      tick(row_name + " v" + std::to_string(v) + " frame " + std::to_string(frame));
    }
  }

  for (std::size_t i = 0; i < count; ++i) {
    CellResult& c = row.cells[i];
    if (c.status != CellStatus::Ran) continue;
    c.frames = static_cast<std::uint32_t>(reported[i].size());
    if (c.frames == 0) {
      c.status = CellStatus::Skipped;
      if (c.note.empty()) c.note = "no timed frame";
      continue;
    }
    c.median_ms = median(reported[i]);
    c.p99_ms = percentile(reported[i], 0.99);
    c.min_ms = *std::min_element(reported[i].begin(), reported[i].end());
    c.max_ms = *std::max_element(reported[i].begin(), reported[i].end());
    c.median_wall_ms = median(wall[i]);
    c.median_cpu_ms = median(cpu[i]);
    c.median_raw_pairs = static_cast<std::uint64_t>(median(raw[i]));
    c.setup_s = setup[i] / config_.variants;
    c.peak_bytes = std::max(peak_bytes[i], memory[i].peak_bytes());
    c.memory_measured = memory[i].measured();
    history_[i].push_back({n, c.median_wall_ms, c.median_ms, c.setup_s});
  }
  row.median_pairs = static_cast<std::uint64_t>(median(ref_pairs));
  for (auto& c : row.cells)
    if (c.status == CellStatus::Ran && c.median_ms > 0)
      c.pairs_per_s = static_cast<double>(row.median_pairs) / (c.median_ms * 1e-3);
  result_.rows.push_back(std::move(row));
}

}  // namespace hbp::cli
