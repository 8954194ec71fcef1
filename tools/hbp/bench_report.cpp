// SPDX-License-Identifier: MIT
#include "bench_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "hbp/benchdata/paper_table4.hpp"
#include "csv.hpp"
#include "duration_text.hpp"
#include "hbp/error.hpp"

namespace hbp::cli {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using hw::PaperTable4Row;
using hw::paper_table4_row;

// A blank entry of the paper's table as NaN (printed blank, skipped by the minima).
double or_nan(const std::optional<double>& v) { return v ? *v : kNaN; }

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Milliseconds with the paper's precision for small values.
std::string fmt_ms(double v) {
  if (std::isnan(v)) return "";
  if (v >= 100) return fmt("%.1f", v);
  if (v >= 1) return fmt("%.3f", v);
  if (v >= 0.01) return fmt("%.4f", v);
  return fmt("%.6f", v);
}

std::string fmt_factor(double v) {
  if (std::isnan(v) || std::isinf(v)) return "";
  if (v >= 100) return fmt("%.0fx", v);
  if (v >= 10) return fmt("%.1fx", v);
  return fmt("%.2fx", v);
}

const char* status_name(CellStatus s) {
  switch (s) {
    case CellStatus::Ran: return "ran";
    case CellStatus::Skipped: return "skipped";
    case CellStatus::NotApplicable: return "n/a";
    case CellStatus::Failed: return "failed";
    case CellStatus::Projected: return "projected";
  }
  return "?";
}

std::string fmt_bytes(std::uint64_t b) {
  if (b == 0) return "";
  const double mb = static_cast<double>(b) / (1024.0 * 1024.0);
  if (mb >= 1024) return fmt("%.2f GB", mb / 1024);
  if (mb >= 10) return fmt("%.0f MB", mb);
  return fmt("%.1f MB", mb);
}

std::string fmt_rate(double per_s) {
  if (!(per_s > 0)) return "";
  if (per_s >= 1e9) return fmt("%.2f G", per_s * 1e-9);
  if (per_s >= 1e6) return fmt("%.1f M", per_s * 1e-6);
  if (per_s >= 1e3) return fmt("%.1f k", per_s * 1e-3);
  return fmt("%.0f", per_s);
}

std::string fmt_seconds_as_ms(double s) { return fmt_ms(s * 1e3); }

// "~12.5 (projected)" (appended piecewise: GCC 12 warns falsely on
// "literal" + string temporaries under -O3).
std::string projected_text(const std::string& value) {
  std::string t = "~";
  t += value;
  t += " (projected)";
  return t;
}

int index_of(const BenchResult& r, const std::string& key) {
  for (std::size_t i = 0; i < r.keys.size(); ++i)
    if (r.keys[i] == key) return static_cast<int>(i);
  return -1;
}

// Median of a system in a row, or NaN when it did not run.
double median_of(const BenchResult& r, const RowResult& row, const std::string& key) {
  const int i = index_of(r, key);
  if (i < 0) return kNaN;
  const CellResult& c = row.cells[static_cast<std::size_t>(i)];
  return c.status == CellStatus::Ran && c.frames > 0 ? c.median_ms : kNaN;
}

double min_ignoring_nan(std::initializer_list<double> vs) {
  double m = kNaN;
  for (double v : vs)
    if (!std::isnan(v) && (std::isnan(m) || v < m)) m = v;
  return m;
}

std::string column_label(const BenchResult& r, std::size_t i) {
  return r.labels[i] + (r.modelled[i] ? " (model)" : " (m)");
}

// The fastest measured system of a row (lowest median among systems that
// ran on this machine and matched the reference every frame), or -1.
int fastest_measured(const BenchResult& r, const RowResult& row) {
  int best = -1;
  for (std::size_t i = 0; i < row.cells.size(); ++i) {
    const CellResult& c = row.cells[i];
    if (r.modelled[i] || c.status != CellStatus::Ran || c.frames == 0 || c.mismatched_frames) continue;
    if (best < 0 || c.median_ms < row.cells[static_cast<std::size_t>(best)].median_ms) best = static_cast<int>(i);
  }
  return best;
}

// The lowest projected median of a row, among systems projected there.
int fastest_projected(const BenchResult& r, const RowResult& row) {
  int best = -1;
  for (std::size_t i = 0; i < row.cells.size(); ++i) {
    const CellResult& c = row.cells[i];
    if (r.modelled[i] || c.status != CellStatus::Projected) continue;
    if (best < 0 || c.projected_ms < row.cells[static_cast<std::size_t>(best)].projected_ms)
      best = static_cast<int>(i);
  }
  return best;
}

std::string cell_text(const CellResult& c) {
  switch (c.status) {
    case CellStatus::NotApplicable: return "n/a";
    case CellStatus::Skipped: return c.note;
    case CellStatus::Failed: return "FAILED";
    case CellStatus::Projected: return projected_text(fmt_ms(c.projected_ms));
    case CellStatus::Ran: break;
  }
  std::string s = fmt_ms(c.median_ms);
  if (c.mismatched_frames) s += " MISMATCH x" + std::to_string(c.mismatched_frames);
  if (!c.note.empty()) s += " *";
  return s;
}

void table_row(std::ostringstream& o, const std::vector<std::string>& cells) {
  o << "|";
  for (const auto& c : cells) o << " " << c << " |";
  o << "\n";
}

void table_head(std::ostringstream& o, const std::vector<std::string>& cells) {
  table_row(o, cells);
  o << "|";
  for (std::size_t i = 0; i < cells.size(); ++i) o << (i == 0 ? " ---: |" : " ---: |");
  o << "\n";
}

double paper_ae_best(const PaperTable4Row& p) { return min_ignoring_nan({or_nan(p.area_efficient_none), or_nan(p.area_efficient_1024)}); }
double paper_mo_best(const PaperTable4Row& p) {
  return min_ignoring_nan({or_nan(p.many_object_none), or_nan(p.many_object_cells[0]), or_nan(p.many_object_cells[1]),
                           or_nan(p.many_object_cells[2]), or_nan(p.many_object_cells[3]),
                           or_nan(p.many_object_cells[4])});
}
double ours_ae_best(const BenchResult& r, const RowResult& row) {
  return min_ignoring_nan({median_of(r, row, "ae-none"), median_of(r, row, "ae-1024")});
}
double ours_mo_best(const BenchResult& r, const RowResult& row) {
  return min_ignoring_nan({median_of(r, row, "mo-none"), median_of(r, row, "mo-1024"), median_of(r, row, "mo-2048"),
                           median_of(r, row, "mo-4096"), median_of(r, row, "mo-8192"),
                           median_of(r, row, "mo-16384")});
}

std::string header_text(const BenchHeader& h) {
  std::ostringstream o;
  const BenchConfig& c = h.config;
  o << "# hbp bench: " << h.title << "\n\n";
  o << "Command: `" << h.command << "`  \n";
  o << "Started: " << h.started << "  \n";
  o << "Frames: " << h.scene << "  \n";
  o << "Per row: " << c.variants << " variant(s) x " << c.frames << " timed frame(s), after " << c.warmup
    << " untimed warm-up frame(s) and an untimed setup frame (the paper: 20 variants x 1000 frames). "
    << "Medians over all timed frames.  \n";
  o << "Clock: " << (c.choice.clock == BenchClock::Cpu
                        ? "CPU time of the calling thread (all work runs on it with --threads 1; robust to other "
                          "load on the machine)"
                        : "wall time (steady_clock)")
    << " for measured systems.  \n";
  o << "Threads: our software hybrid and the models' partition run with " << c.choice.threads
    << " thread(s); Bullet and CGAL are single-threaded.  \n";
  o << "Budget: a system is not run in a row when the time it would take there (setup + frames, projected "
       "from its earlier rows) exceeds "
    << format_duration(c.budget_s);
  for (const auto& [k, secs] : c.budget_for) o << ", " << k << " " << format_duration(secs);
  o << "; its cell then shows the projected median, marked \"(projected)\", extrapolated from its last two "
       "measured rows (time ~ n^e, e fitted, 1 <= e <= 2.2) and never counted as measured. A system is also "
       "stopped in a row once it has spent twice its budget there.  \n";
  o << "Memory: peak resident memory attributed to each system, in this process: the growth of VmRSS/VmHWM "
       "(/proc/self/status; the peak reset through /proc/self/clear_refs) around each of its own calls (setup "
       "and every frame), on top of what it retained from its earlier calls; the heap is trimmed before each "
       "setup. Input boxes and the frame generator are not counted; pages the allocator reuses from another "
       "system's frees are not seen, so it is a lower bound.  \n";
  o << "Machine:\n\n";
  for (const auto& [k, v] : h.machine) o << "- " << k << ": " << v << "\n";
  o << "\n";
  return o.str();
}

}  // namespace

std::string format_summary(const BenchResult& r) {
  std::ostringstream o;
  const int reference = index_of(r, r.reference);
  const int dbvt = index_of(r, "bullet-dbvt");
  o << "Median time per frame, " << r.keys.size() << " system(s):\n";
  for (const auto& row : r.rows) {
    o << "  n = " << row.n << ", " << row.median_pairs << " pairs: ";
    const int f = fastest_measured(r, row);
    if (f < 0) {
      o << "no measured system completed";
    } else {
      o << "fastest " << r.labels[static_cast<std::size_t>(f)] << " "
        << fmt_ms(row.cells[static_cast<std::size_t>(f)].median_ms) << " ms";
    }
    for (const int i : {reference, dbvt}) {
      if (i < 0 || i == f) continue;
      o << "; " << r.labels[static_cast<std::size_t>(i)] << " " << cell_text(row.cells[static_cast<std::size_t>(i)])
        << (row.cells[static_cast<std::size_t>(i)].status == CellStatus::Ran ? " ms" : "");
    }
    o << "\n";
  }
  if (r.mismatches.empty()) {
    o << "Every system's pairs matched " << r.reference << "'s every frame.\n";
  } else {
    o << "MISMATCH: " << r.mismatches.size() << " frame(s) where a system's pairs differed from " << r.reference
      << "'s (listed in tables.md).\n";
  }
  return o.str();
}

std::string format_tables(const BenchResult& r, const BenchHeader& h) {
  std::ostringstream o;
  o << header_text(h);
  const int dbvt = index_of(r, "bullet-dbvt");

  // 1. Medians.
  o << "## Median time per frame (ms)\n\n";
  std::vector<std::string> head = {"n", "pairs"};
  for (std::size_t i = 0; i < r.keys.size(); ++i) head.push_back(column_label(r, i));
  if (h.paper) head.push_back("GPU");
  head.push_back("fastest measured");
  table_head(o, head);
  for (const auto& row : r.rows) {
    const bool any_ran = std::any_of(row.cells.begin(), row.cells.end(),
                                     [](const CellResult& c) { return c.status == CellStatus::Ran && c.frames > 0; });
    std::vector<std::string> cells = {std::to_string(row.n), any_ran ? std::to_string(row.median_pairs) : ""};
    for (const auto& c : row.cells) cells.push_back(cell_text(c));
    if (h.paper) cells.push_back("not run");
    const int f = fastest_measured(r, row);
    cells.push_back(f < 0 ? "" : r.labels[static_cast<std::size_t>(f)]);
    table_row(o, cells);
  }
  o << "\n(m): measured " << (h.config.choice.clock == BenchClock::Cpu ? "CPU" : "wall")
    << " time of one frame on this machine (Bullet: setAabb of every proxy + "
       "calculateOverlappingPairs; CGAL: box copy + box_self_intersection_d; hybrid sw: HybridBroadPhase::update, "
       "partition included, pairs in cell order (sorted = false: deterministic, unordered like the baselines' sets); "
       "hybrid sw, sorted: the same with the list sorted by (a, b), the library's default).  \n"
       "(model): modelled accelerator time, cycles at the model's clock (500 MHz, m = 16), spatial partition "
       "excluded as in the paper; \"none\" = the whole world in one accelerator load, only up to its capacity "
       "(1024 area-efficient, 16,384 many-object), else n/a like the paper; a cell size is used only when n "
       "exceeds it.  \n"
    << (h.paper ? "GPU: the paper's GPU column is Bullet's OpenCL sweep and prune on a GeForce GTX 670. Our GPU "
                  "frame is not run by `hbp bench` (it needs a GPU machine): its column below comes from the "
                  "stored GPU run, labelled with its GPU and date, or reads not measured.  \n"
                : "")
    << "~x (projected): not run at this size (over budget), projected from the system's measured rows.  \n"
       "fastest measured: lowest median among the measured (m) systems that ran at this size and matched the "
       "reference every frame.  \n"
       "Every system's exact pair set (Bullet's pair cache filtered with the closed-interval test) is compared "
       "with " << r.reference << "'s every frame; MISMATCH xk marks k frames that differed (listed below).\n";
  bool notes = false;
  for (const auto& row : r.rows)
    for (std::size_t i = 0; i < row.cells.size(); ++i) {
      const CellResult& c = row.cells[i];
      if ((c.status == CellStatus::Ran && !c.note.empty()) || c.status == CellStatus::Failed) {
        if (!notes) o << "\nNotes:\n\n";
        notes = true;
        o << "- n=" << row.n << ", " << r.labels[i] << ": " << (c.status == CellStatus::Failed ? "FAILED, " : "* ")
          << c.note << "\n";
      }
    }
  if (!r.missing.empty()) {
    o << "\nNot in this binary: ";
    for (std::size_t i = 0; i < r.missing.size(); ++i) o << (i ? "; " : "") << r.missing[i];
    o << ".\n";
  }

  // 1b. Every system per row: the distribution, the first frame, the rate,
  // the memory.
  o << "\n## Per system: median, p99 and worst frame, first frame, pairs per second, peak memory\n\n";
  table_head(o, {"n", "system", "median ms", "p99 ms", "worst ms", "first frame (setup) ms", "pairs/s",
                 "peak memory", "raw pairs", "frames", "status"});
  for (const auto& row : r.rows) {
    for (std::size_t i = 0; i < row.cells.size(); ++i) {
      const CellResult& c = row.cells[i];
      if (c.status == CellStatus::NotApplicable) continue;
      if (c.status == CellStatus::Projected) {
        table_row(o, {std::to_string(row.n), column_label(r, i), projected_text(fmt_ms(c.projected_ms)), "",
                      "", projected_text(fmt_seconds_as_ms(c.projected_setup_s)), "", "", "", "0",
                      c.note});
        continue;
      }
      if (c.status != CellStatus::Ran) {
        table_row(o, {std::to_string(row.n), column_label(r, i), "", "", "", "", "", "", "", "0",
                      c.status == CellStatus::Failed ? "FAILED: " + c.note : c.note});
        continue;
      }
      std::string status = c.mismatched_frames ? "MISMATCH x" + std::to_string(c.mismatched_frames) : "exact";
      if (!c.note.empty()) status += "; " + c.note;
      table_row(o, {std::to_string(row.n), column_label(r, i), fmt_ms(c.median_ms), fmt_ms(c.p99_ms),
                    fmt_ms(c.max_ms), fmt_seconds_as_ms(c.setup_s), fmt_rate(c.pairs_per_s),
                    c.memory_measured ? fmt_bytes(c.peak_bytes) : "not measured", std::to_string(c.median_raw_pairs),
                    std::to_string(c.frames), status});
    }
  }
  o << "\nmedian / p99 / worst: over every timed frame of the row (p99 by nearest rank: with fewer than 100 "
       "frames it is the worst or next-to-worst). First frame: the untimed setup (wall time, mean per variant): "
       "proxies or geoms created and the first pairs found; for rebuild-every-frame systems (CGAL, brute force) "
       "one ordinary frame. pairs/s: the reference's exact pairs per second of median frame time. Peak memory: "
       "see Memory above.\n";

  // Fastest per size.
  o << "\n## Fastest per size\n\n";
  table_head(o, {"n", "fastest measured", "median ms", "runner-up measured", "median ms",
                 "fastest projected (not run)", "projected ms"});
  for (const auto& row : r.rows) {
    const int f = fastest_measured(r, row);
    int second = -1;
    for (std::size_t i = 0; i < row.cells.size(); ++i) {
      const CellResult& c = row.cells[i];
      if (static_cast<int>(i) == f || r.modelled[i] || c.status != CellStatus::Ran || c.frames == 0 ||
          c.mismatched_frames)
        continue;
      if (second < 0 || c.median_ms < row.cells[static_cast<std::size_t>(second)].median_ms)
        second = static_cast<int>(i);
    }
    const int p = fastest_projected(r, row);
    auto label = [&](int i) { return i < 0 ? std::string() : r.labels[static_cast<std::size_t>(i)]; };
    auto med = [&](int i) { return i < 0 ? std::string() : fmt_ms(row.cells[static_cast<std::size_t>(i)].median_ms); };
    table_row(o, {std::to_string(row.n), label(f), med(f), label(second), med(second), label(p),
                  p < 0 ? "" : fmt_ms(row.cells[static_cast<std::size_t>(p)].projected_ms)});
  }

  // 2. Acceleration factors against Bullet DBVT.
  if (dbvt >= 0) {
    o << "\n## Acceleration against Bullet DBVT (DBVT median / system median, same run)\n\n";
    std::vector<std::string> ah = {"n"};
    for (std::size_t i = 0; i < r.keys.size(); ++i)
      if (static_cast<int>(i) != dbvt) ah.push_back(column_label(r, i));
    table_head(o, ah);
    for (const auto& row : r.rows) {
      const double base = median_of(r, row, "bullet-dbvt");
      std::vector<std::string> cells = {std::to_string(row.n)};
      for (std::size_t i = 0; i < r.keys.size(); ++i) {
        if (static_cast<int>(i) == dbvt) continue;
        const double v = median_of(r, row, r.keys[i]);
        cells.push_back(std::isnan(base) || std::isnan(v) ? "" : fmt_factor(base / v));
      }
      table_row(o, cells);
    }
  }

  // 3. The paper beside ours.
  if (h.paper) {
    o << "\n## Beside the paper's Table 4 (ms; acceleration = Bullet DBVT / best area-efficient, Fig. 4's "
         "quantity)\n\n";
    table_head(o, {"n", "DBVT here (m)", "DBVT paper", "AE best here (model)", "AE best paper",
                   "MO best here (model)", "MO best paper", "accel here", "accel paper", "hybrid sw here (m)",
                   "sw accel here", "GPU paper"});
    for (const auto& row : r.rows) {
      const PaperTable4Row* p = paper_table4_row(row.n);
      const double d = median_of(r, row, "bullet-dbvt");
      const double ae = ours_ae_best(r, row), mo = ours_mo_best(r, row), sw = median_of(r, row, "sw");
      table_row(o, {std::to_string(row.n), fmt_ms(d), p ? fmt_ms(p->cpu_ms) : "", fmt_ms(ae),
                    p ? fmt_ms(paper_ae_best(*p)) : "", fmt_ms(mo), p ? fmt_ms(paper_mo_best(*p)) : "",
                    fmt_factor(d / ae), p ? fmt_factor(p->cpu_ms / paper_ae_best(*p)) : "", fmt_ms(sw),
                    fmt_factor(d / sw), p ? fmt_ms(p->gpu_ms) : ""});
    }
    o << "\nThe paper's CPU is a 2 GHz quad-core AMD Opteron 2350 (2007) running Bullet's DBVT; its modelled "
         "times come from FPGA throughput scaled to 500 MHz. \"here\" is this run.\n";
    o << "\n## The paper's Table 4 as published (ms), for the rows of this run\n\n";
    table_head(o, {"n", "CPU", "GPU", "AE none", "AE 1024", "MO none", "MO 1024", "MO 2048", "MO 4096", "MO 8192",
                   "MO 16384"});
    for (const auto& row : r.rows) {
      const PaperTable4Row* p = paper_table4_row(row.n);
      if (!p) continue;
      table_row(o, {std::to_string(p->n), fmt_ms(p->cpu_ms), fmt_ms(p->gpu_ms), fmt_ms(or_nan(p->area_efficient_none)), fmt_ms(or_nan(p->area_efficient_1024)),
                    fmt_ms(or_nan(p->many_object_none)), fmt_ms(or_nan(p->many_object_cells[0])), fmt_ms(or_nan(p->many_object_cells[1])), fmt_ms(or_nan(p->many_object_cells[2])),
                    fmt_ms(or_nan(p->many_object_cells[3])), fmt_ms(or_nan(p->many_object_cells[4]))});
    }
  }

  // The paper's GPU column and Table 5, from the stored GPU run.
  if (h.paper) {
    o << "\n## The GPU column (Table 4) and Table 5\n\n";
    const std::optional<GpuReport> gpu = read_gpu_report(h.gpu_report);
    if (!gpu) {
      o << "Our GPU frame: not measured (no GPU report at " << h.gpu_report
        << "; scripts/gpu-check on a GPU machine writes one).\n";
    } else {
      o << "Measured on " << gpu->gpu << " (" << gpu->date << ", " << h.gpu_report
        << "), not in this run: device time per frame, boxes resident on the GPU, pairs sorted; the paper's "
           "GPU column is Bullet's OpenCL sweep and prune on a GeForce GTX 670.\n\n";
      table_head(o, {"n", "our GPU frame", "GPU paper", "paper GPU / ours", "AE best paper (model)",
                     "paper AE / ours"});
      for (const auto& row : r.rows) {
        const PaperTable4Row* p = paper_table4_row(row.n);
        const auto g = gpu->paper_frame_ms.find(row.n);
        if (g == gpu->paper_frame_ms.end()) continue;
        table_row(o, {std::to_string(row.n), fmt_ms(g->second), p ? fmt_ms(p->gpu_ms) : "",
                      p ? fmt_factor(p->gpu_ms / g->second) : "", p ? fmt_ms(paper_ae_best(*p)) : "",
                      p ? fmt_factor(paper_ae_best(*p) / g->second) : ""});
      }
      const GpuPaperFrame& f = gpu->paper;
      o << "\nAt 1,024,000 objects on " << gpu->gpu << ": our GPU frame " << fmt_ms(f.frame_ms) << " ms ("
        << fmt_ms(f.with_transfers_ms) << " ms with host transfers)";
      if (f.axis_sweep_ms > 0) o << "; our GPU one-axis sort and sweep " << fmt_ms(f.axis_sweep_ms) << " ms";
      if (f.lbvh_ms > 0) o << "; our GPU LBVH " << fmt_ms(f.lbvh_ms) << " ms";
      if (f.cpu_sw_ms > 0) o << "; our CPU engine on that machine (" << gpu->host << ") " << fmt_ms(f.cpu_sw_ms) << " ms";
      if (f.cells_accelerator_ms > 0)
        o << "; the paper's split, our CPU's cells streamed to the GPU as the accelerator (the `cuda` engine's time, "
             "partition excluded) "
          << fmt_ms(f.cells_accelerator_ms) << " ms";
      if (f.energy_per_frame_j > 0) o << "; " << fmt_ms(f.energy_per_frame_j * 1000) << " mJ per frame (board power)";
      o << ".\n\nTable 5 (published GPU broad phases, their machines and scenes): Liu et al. 161 ms at 960,000 "
           "objects, Avril et al. 245.95 ms at 1,000,000; Bullet3's GPU sort and sweep 1,958.9 ms at 1,024,000 "
           "(Table 4).\n";
    }
  }

  // 4. Mismatches, never hidden.
  o << "\n## Pair-set check\n\n";
  if (r.mismatches.empty()) {
    o << "Every system that ran found exactly the reference's pairs in every timed frame.\n";
  } else {
    o << r.mismatches.size() << " frame(s) differed:\n\n";
    for (const auto& m : r.mismatches)
      o << "- n=" << m.n << " variant " << m.variant << " frame " << m.frame << ": " << m.system << " vs "
        << m.reference << ": " << m.summary << "\n";
  }
  o << "\nTotal run time: " << format_duration(r.total_s) << ".\n";
  return o.str();
}

namespace {

const char* kind_name(const BenchResult& r, std::size_t i) { return r.modelled[i] ? "modelled" : "measured"; }

// samples.csv: every timed frame of every system.
void write_samples_csv(std::ostream& f, const BenchResult& r) {
  f << "n,variant,frame,system,label,kind,ms,wall_ms,cpu_ms,raw_pairs,exact_pairs,match\n";
  for (const auto& s : r.samples)
    f << s.n << "," << s.variant << "," << s.frame << "," << r.keys[s.system] << "," << csv_field(r.labels[s.system])
      << "," << kind_name(r, s.system) << "," << fmt("%.6f", s.reported_ms) << "," << fmt("%.6f", s.wall_ms) << ","
      << fmt("%.6f", s.cpu_ms) << "," << s.raw_pairs << "," << s.exact_pairs << "," << (s.match ? 1 : 0) << "\n";
}

// summary.csv: one line per system per row.
void write_summary_csv(std::ostream& f, const BenchResult& r) {
  f << "n,system,label,kind,status,median_ms,p99_ms,min_ms,max_ms,median_wall_ms,median_cpu_ms,setup_s,"
       "pairs_per_s,peak_bytes,frames,mismatched_frames,median_raw_pairs,reference_pairs,projected_ms,"
       "projected_setup_s,note\n";
  for (const auto& row : r.rows)
    for (std::size_t i = 0; i < row.cells.size(); ++i) {
      const CellResult& c = row.cells[i];
      f << row.n << "," << r.keys[i] << "," << csv_field(r.labels[i]) << "," << kind_name(r, i) << ","
        << status_name(c.status) << "," << fmt("%.6f", c.median_ms) << "," << fmt("%.6f", c.p99_ms) << ","
        << fmt("%.6f", c.min_ms) << "," << fmt("%.6f", c.max_ms) << "," << fmt("%.6f", c.median_wall_ms) << ","
        << fmt("%.6f", c.median_cpu_ms) << "," << fmt("%.6f", c.setup_s) << "," << fmt("%.1f", c.pairs_per_s)
        << "," << (c.memory_measured ? std::to_string(c.peak_bytes) : std::string()) << "," << c.frames << ","
        << c.mismatched_frames << "," << c.median_raw_pairs << "," << row.median_pairs << ","
        << fmt("%.6f", c.projected_ms) << "," << fmt("%.6f", c.projected_setup_s) << "," << csv_field(c.note)
        << "\n";
    }
}

// report.json: parameters, machine, every row, mismatch and sample.
void write_report_json(std::ostream& f, const BenchResult& r, const BenchHeader& h) {
  nlohmann::json j;
  j["tool"] = "hbp bench";
  j["title"] = h.title;
  j["command"] = h.command;
  j["started"] = h.started;
  j["frames_description"] = h.scene;
  j["parameters"] = {{"frames", h.config.frames},     {"variants", h.config.variants},
                     {"warmup", h.config.warmup},     {"threads", h.config.choice.threads},
                     {"budget_s", h.config.budget_s}, {"reference", r.reference},
                     {"clock", h.config.choice.clock == BenchClock::Cpu ? "cpu" : "wall"}};
  for (const auto& [k, secs] : h.config.budget_for) j["parameters"]["budget_for_s"][k] = secs;
  for (const auto& [k, v] : h.machine) j["machine"][k] = v;
  j["total_s"] = r.total_s;
  j["not_built"] = r.missing;
  // The GPU column: from the stored GPU run, never this one (gpu_report.hpp).
  if (h.paper) {
    if (const std::optional<GpuReport> gpu = read_gpu_report(h.gpu_report)) {
      nlohmann::json rows = nlohmann::json::object();
      for (const auto& [n, ms] : gpu->paper_frame_ms) rows[std::to_string(n)] = ms;
      j["gpu_column"] = {{"measured", true},        {"gpu", gpu->gpu},           {"date", gpu->date},
                         {"report", h.gpu_report},  {"frame_ms_by_n", rows},
                         {"paper_1024000", {{"frame_ms", gpu->paper.frame_ms},
                                            {"with_transfers_ms", gpu->paper.with_transfers_ms},
                                            {"axis_sweep_ms", gpu->paper.axis_sweep_ms},
                                            {"lbvh_ms", gpu->paper.lbvh_ms},
                                            {"cpu_sw_ms", gpu->paper.cpu_sw_ms},
                                            {"cells_accelerator_ms", gpu->paper.cells_accelerator_ms},
                                            {"energy_per_frame_j", gpu->paper.energy_per_frame_j}}}};
    } else {
      j["gpu_column"] = {{"measured", false}, {"report", h.gpu_report}};
    }
  }
  for (std::size_t i = 0; i < r.keys.size(); ++i)
    j["systems"].push_back({{"key", r.keys[i]}, {"label", r.labels[i]}, {"kind", kind_name(r, i)}});
  for (const auto& row : r.rows) {
    nlohmann::json jr = {{"n", row.n}, {"reference_pairs", row.median_pairs}};
    for (std::size_t i = 0; i < row.cells.size(); ++i) {
      const CellResult& c = row.cells[i];
      jr["systems"][r.keys[i]] = {{"status", status_name(c.status)},
                                  {"median_ms", c.median_ms},
                                  {"min_ms", c.min_ms},
                                  {"max_ms", c.max_ms},
                                  {"p99_ms", c.p99_ms},
                                  {"pairs_per_s", c.pairs_per_s},
                                  {"peak_bytes", c.memory_measured ? nlohmann::json(c.peak_bytes)
                                                                   : nlohmann::json(nullptr)},
                                  {"projected_ms", c.projected_ms},
                                  {"projected_setup_s", c.projected_setup_s},
                                  {"median_wall_ms", c.median_wall_ms},
                                  {"median_cpu_ms", c.median_cpu_ms},
                                  {"setup_s", c.setup_s},
                                  {"frames", c.frames},
                                  {"mismatched_frames", c.mismatched_frames},
                                  {"median_raw_pairs", c.median_raw_pairs},
                                  {"note", c.note}};
    }
    if (const PaperTable4Row* p = paper_table4_row(row.n); p && h.paper) {
      auto num = [](double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); };
      jr["paper_table4"] = {{"cpu", num(p->cpu_ms)},         {"gpu", num(p->gpu_ms)},
                            {"ae_none", num(or_nan(p->area_efficient_none))}, {"ae_1024", num(or_nan(p->area_efficient_1024))},
                            {"mo_none", num(or_nan(p->many_object_none))}, {"mo_1024", num(or_nan(p->many_object_cells[0]))},
                            {"mo_2048", num(or_nan(p->many_object_cells[1]))}, {"mo_4096", num(or_nan(p->many_object_cells[2]))},
                            {"mo_8192", num(or_nan(p->many_object_cells[3]))}, {"mo_16384", num(or_nan(p->many_object_cells[4]))}};
    }
    j["rows"].push_back(jr);
  }
  j["mismatches"] = nlohmann::json::array();
  for (const auto& m : r.mismatches)
    j["mismatches"].push_back({{"n", m.n},
                               {"variant", m.variant},
                               {"frame", m.frame},
                               {"system", m.system},
                               {"reference", m.reference},
                               {"summary", m.summary}});
  j["samples"] = nlohmann::json::array();
  for (const auto& s : r.samples)
    j["samples"].push_back({{"n", s.n},
                            {"variant", s.variant},
                            {"frame", s.frame},
                            {"system", r.keys[s.system]},
                            {"ms", s.reported_ms},
                            {"wall_ms", s.wall_ms},
                            {"cpu_ms", s.cpu_ms},
                            {"raw_pairs", s.raw_pairs},
                            {"exact_pairs", s.exact_pairs},
                            {"match", s.match}});
  f << j.dump(1) << "\n";
}

// Plot data (times.dat, accel.dat): whitespace-separated, "?" for a missing
// value, quoted titles.

// times.dat: median ms per system and n; the paper's curves; projections.
void write_times_dat(std::ostream& f, const BenchResult& r, const BenchHeader& h) {
  // Systems projected somewhere get a second column: the projected
  // medians, starting at the last measured row so the curve continues.
  std::vector<std::size_t> projected;
  for (std::size_t i = 0; i < r.keys.size(); ++i)
    for (const auto& row : r.rows)
      if (row.cells[i].status == CellStatus::Projected) {
        projected.push_back(i);
        break;
      }
  f << "n";
  for (std::size_t i = 0; i < r.keys.size(); ++i) f << " \"" << column_label(r, i) << "\"";
  if (h.paper) f << " \"paper CPU (DBVT)\" \"paper AE best (model)\"";
  for (std::size_t i : projected) f << " \"" << r.labels[i] << " (projected)\"";
  f << "\n";
  for (std::size_t k = 0; k < r.rows.size(); ++k) {
    const RowResult& row = r.rows[k];
    f << row.n;
    for (const auto& key : r.keys) {
      const double v = median_of(r, row, key);
      f << " " << (std::isnan(v) ? std::string("?") : fmt("%.9g", v));
    }
    if (h.paper) {
      const PaperTable4Row* p = paper_table4_row(row.n);
      f << " " << (p ? fmt("%.9g", p->cpu_ms) : "?") << " " << (p ? fmt("%.9g", paper_ae_best(*p)) : "?");
    }
    for (std::size_t i : projected) {
      const CellResult& c = row.cells[i];
      const bool next_projected = k + 1 < r.rows.size() && r.rows[k + 1].cells[i].status == CellStatus::Projected;
      if (c.status == CellStatus::Projected) f << " " << fmt("%.9g", c.projected_ms);
      else if (c.status == CellStatus::Ran && c.frames > 0 && next_projected) f << " " << fmt("%.9g", c.median_ms);
      else f << " ?";
    }
    f << "\n";
  }
}

// accel.dat: acceleration against Bullet DBVT per system and n (Fig. 4).
void write_accel_dat(std::ostream& f, const BenchResult& r, const BenchHeader& h) {
  f << "n";
  for (std::size_t i = 0; i < r.keys.size(); ++i)
    if (r.keys[i] != "bullet-dbvt") f << " \"" << column_label(r, i) << "\"";
  f << " \"AE best (model)\" \"MO best (model)\"";
  if (h.paper) f << " \"paper: AE best vs CPU\" \"paper: AE best vs GPU\"";
  f << "\n";
  for (const auto& row : r.rows) {
    const double base = median_of(r, row, "bullet-dbvt");
    auto factor = [&](double v) {
      return std::isnan(base) || std::isnan(v) ? std::string("?") : fmt("%.9g", base / v);
    };
    f << row.n;
    for (const auto& key : r.keys)
      if (key != "bullet-dbvt") f << " " << factor(median_of(r, row, key));
    f << " " << factor(ours_ae_best(r, row)) << " " << factor(ours_mo_best(r, row));
    if (h.paper) {
      const PaperTable4Row* p = paper_table4_row(row.n);
      f << " " << (p ? fmt("%.9g", p->cpu_ms / paper_ae_best(*p)) : "?") << " "
        << (p ? fmt("%.9g", p->gpu_ms / paper_ae_best(*p)) : "?");
    }
    f << "\n";
  }
}

}  // namespace

std::vector<std::string> write_report_files(const std::string& dir, const BenchResult& r, const BenchHeader& h) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw FileError("cannot create output directory '" + dir + "': " + ec.message());
  using Writer = void (*)(std::ostream&, const BenchResult&, const BenchHeader&);
  const std::pair<const char*, Writer> files[] = {
      {"tables.md", [](std::ostream& f, const BenchResult& r, const BenchHeader& h) { f << format_tables(r, h); }},
      {"samples.csv", [](std::ostream& f, const BenchResult& r, const BenchHeader&) { write_samples_csv(f, r); }},
      {"summary.csv", [](std::ostream& f, const BenchResult& r, const BenchHeader&) { write_summary_csv(f, r); }},
      {"report.json", write_report_json},
      {"times.dat", write_times_dat},
      {"accel.dat", write_accel_dat},
  };
  std::vector<std::string> written;
  for (const auto& [name, write] : files) {
    const std::string path = (fs::path(dir) / name).string();
    std::ofstream f(path);
    if (!f) throw FileError("cannot write '" + path + "'");
    written.push_back(path);
    write(f, r, h);
    f.close();
    if (!f) throw FileError("cannot write '" + path + "' (disk full?)");
  }
  return written;
}

}  // namespace hbp::cli
