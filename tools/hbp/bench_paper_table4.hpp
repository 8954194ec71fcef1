#pragma once
// The paper's Table 4 as the bench report reads it: a flat row of doubles
// with NaN for a blank cell, derived from the one transcription of the table
// in the library (include/hbp/hw/paper_table4.hpp).
#include <cstdint>
#include <limits>
#include <vector>

#include "hbp/benchdata/paper_table4.hpp"

namespace hbp::cli {

struct PaperTable4Row {
  std::uint32_t n;
  double cpu, gpu;
  double ae_none, ae_1024;
  double mo_none, mo_1024, mo_2048, mo_4096, mo_8192, mo_16384;
};

inline constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

inline const std::vector<PaperTable4Row>& paper_table4_rows() {
  static const std::vector<PaperTable4Row> rows = [] {
    auto v = [](const std::optional<double>& x) { return x ? *x : kNone; };
    std::vector<PaperTable4Row> out;
    for (const hw::PaperTable4Row& p : hw::paper_table4()) {
      out.push_back({p.n, p.cpu_ms, p.gpu_ms, v(p.area_efficient_none), v(p.area_efficient_1024),
                     v(p.many_object_none), v(p.many_object_cells[0]), v(p.many_object_cells[1]),
                     v(p.many_object_cells[2]), v(p.many_object_cells[3]), v(p.many_object_cells[4])});
    }
    return out;
  }();
  return rows;
}

// The row for n, or nullptr when the paper has none.
inline const PaperTable4Row* paper_table4_row(std::uint32_t n) {
  for (const auto& r : paper_table4_rows())
    if (r.n == n) return &r;
  return nullptr;
}

}  // namespace hbp::cli
