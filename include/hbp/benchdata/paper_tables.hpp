// SPDX-License-Identifier: MIT
#pragma once
// Renders model traces in the layout of the paper's Table 1 (area-efficient)
// and Table 3 (many-object), cell by cell, so tests can compare a run with
// the published sequence and `hbp hw trace` can print it.
//
// The paper's blanking conventions, reproduced here:
//  Table 1: an address >= n is blank, and so is the comparison it would feed.
//  Table 3: addresses are always printed. An object index on a B port is
//  blank when it is >= n. An object index on an A port is blank when it is
//  >= n-1: it sits on the anchor side, and object n-1 has no higher partner,
//  so such an entry never takes part in a kept comparison. The symbols
//  (*, dagger, double dagger, section for comparators 0..3) are printed even
//  on blank entries: they show the multiplexer wiring, not the data. For
//  m > 4 comparator c is marked "[c]".
#include <cstdint>
#include <string>
#include <vector>

#include "hbp/hw/trace.hpp"

namespace hbp::hw {

using TableRows = std::vector<std::vector<std::string>>;

// Header row then one row per issuing cycle, numbered 1.. in issue order
// (bubble cycles, when configured, are not rows: the tables show sequences).
// Columns: cycle, 2m port addresses, 2m-1 comparisons "i-j".
TableRows area_efficient_table(const AreaEfficientTrace& trace, std::uint32_t n);
// Columns: cycle, m A addresses, m A objects, m B addresses, m B objects,
// m multiplexer selectors.
TableRows many_object_table(const ManyObjectTrace& trace, std::uint32_t n);

// Tab-separated lines, one per row.
std::string to_tsv(const TableRows& rows);

}  // namespace hbp::hw
