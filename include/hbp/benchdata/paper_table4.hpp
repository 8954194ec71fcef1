// SPDX-License-Identifier: MIT
#pragma once
// Table 4 of the paper: measured execution times in milliseconds (m = 16,
// 500 MHz) for both microarchitectures without partitioning ("None") and with
// each cell size the paper tried. Absent entries are std::nullopt. Kept as
// data so `hbp hw table`, the bench report and the tests compare against the published values.
#include <cstdint>
#include <optional>
#include <span>

namespace hbp::hw {

struct PaperTable4Row {
  std::uint32_t n;
  double cpu_ms;  // Bullet DBVT
  double gpu_ms;  // Bullet GPU sweep and prune
  std::optional<double> area_efficient_none;
  std::optional<double> area_efficient_1024;
  std::optional<double> many_object_none;
  std::optional<double> many_object_cells[5];  // cell sizes 1024 .. 16384
};

inline constexpr std::uint32_t kPaperCellSizes[5] = {1024, 2048, 4096, 8192, 16384};
inline constexpr std::uint32_t kPaperExtensibility = 16;
inline constexpr double kPaperClockHz = 500e6;

std::span<const PaperTable4Row> paper_table4();
// The row for n, or nullptr when the paper has none.
const PaperTable4Row* paper_table4_row(std::uint32_t n);

}  // namespace hbp::hw
