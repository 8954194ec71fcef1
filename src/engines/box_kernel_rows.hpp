// SPDX-License-Identifier: MIT
#pragma once
// The part of every kernel that does not depend on the instruction set: the
// loop over rows, stopping before a row whose hits might not fit the output
// (box_kernels.hpp), the loop that only counts, and the ISA's KernelSet made
// of them. Each ISA's file supplies its rows (the vector loop over
// candidates) and its hit sinks, and instantiates these once. Everything
// here is in an anonymous namespace: each ISA's translation unit keeps its
// own copy, compiled with its own flags (no one-definition merging across
// ISAs, see box_kernels.hpp).
#include <cstddef>
#include <cstdint>

#include "engines/box_kernels.hpp"

namespace hbp::kernels {
namespace {

// Runs row(i, store) for rows from `row` on while the output has room for a
// whole row plus kOutputSlack; returns the row it stopped at (n when done).
// Store: the ISA's hit sink, {first, second, count} with an emit member.
template <class Store, class Row>
inline std::uint32_t store_rows(const KernelInput& in, std::uint32_t row, KernelOutput& out, Row&& run_row) {
  Store s{out.first, out.second, out.count};
  std::uint32_t i = row;
  for (; i < in.n; ++i) {
    if (out.capacity - s.count < std::size_t{in.n - i} + kOutputSlack) break;
    run_row(i, s);
  }
  out.count = s.count;
  return i;
}

// Runs row(i, count) for rows [row, n) and returns the hits counted.
// Count: the ISA's counting sink, {count} with an emit member.
template <class Count, class Row>
inline std::uint64_t count_rows(const KernelInput& in, std::uint32_t row, Row&& run_row) {
  Count c;
  for (std::uint32_t i = row; i < in.n; ++i) run_row(i, c);
  return c.count;
}

// An ISA's KernelSet from its rows and hit sinks (Store, Count: above).
// Rows provides:
//   Rows::region(CellRegion)        the region as its rows take it (lanes)
//   Rows::sweep_row(in, region, i, out), Rows::allpairs_row(...)
//                                   one row's candidates, templates on the sink
template <class Rows, class Store, class Count>
struct KernelsOf {
  static std::uint32_t sweep(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
    const auto& r = Rows::region(in.region);
    return store_rows<Store>(in, row, out, [&](std::uint32_t i, Store& s) { Rows::sweep_row(in, r, i, s); });
  }
  static std::uint32_t allpairs(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
    const auto& r = Rows::region(in.region);
    return store_rows<Store>(in, row, out, [&](std::uint32_t i, Store& s) { Rows::allpairs_row(in, r, i, s); });
  }
  static std::uint64_t sweep_count(const KernelInput& in, std::uint32_t row) {
    const auto& r = Rows::region(in.region);
    return count_rows<Count>(in, row, [&](std::uint32_t i, Count& c) { Rows::sweep_row(in, r, i, c); });
  }
  static std::uint64_t allpairs_count(const KernelInput& in, std::uint32_t row) {
    const auto& r = Rows::region(in.region);
    return count_rows<Count>(in, row, [&](std::uint32_t i, Count& c) { Rows::allpairs_row(in, r, i, c); });
  }
  static constexpr KernelSet set(CanonicalPairs canonical) {
    return {sweep, allpairs, sweep_count, allpairs_count, canonical};
  }
};

}  // namespace
}  // namespace hbp::kernels
