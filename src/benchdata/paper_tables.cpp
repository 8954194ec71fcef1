// SPDX-License-Identifier: MIT
#include "hbp/benchdata/paper_tables.hpp"

namespace hbp::hw {
namespace {

std::string comparator_mark(std::uint32_t c, std::uint32_t m) {
  static const char* const kPaperSymbols[4] = {"*", "\u2020", "\u2021", "\u00a7"};
  if (m <= 4) return kPaperSymbols[c];
  std::string s = "[";
  s.append(std::to_string(c));
  s.push_back(']');
  return s;
}

// Built by appending: GCC 12 at -O3 warns falsely (-Wrestrict) on
// std::string operator+ chains of short temporaries.
std::string port_name(std::uint32_t group, char port) {
  std::string s = std::to_string(group);
  s.push_back(port);
  return s;
}

std::string pair_text(std::uint32_t a, std::uint32_t b) {
  std::string s = std::to_string(a);
  s.push_back('-');
  s.append(std::to_string(b));
  return s;
}

std::string marked_object(bool shown, std::uint32_t object, const std::string& mark) {
  std::string s = shown ? std::to_string(object) : std::string();
  s.append(mark);
  return s;
}

}  // namespace

TableRows area_efficient_table(const AreaEfficientTrace& trace, std::uint32_t n) {
  TableRows rows;
  if (trace.empty()) return rows;
  const auto ports = static_cast<std::uint32_t>(trace.front().port_address.size());
  std::vector<std::string> header{"Cycle"};
  for (std::uint32_t p = 0; p < ports; ++p) header.push_back(port_name(p / 2, p % 2 ? 'B' : 'A'));
  for (std::uint32_t s = 1; s < ports; ++s) header.push_back(pair_text(0, s));
  rows.push_back(std::move(header));
  std::uint32_t ordinal = 0;
  for (const AreaEfficientCycle& c : trace) {
    std::vector<std::string> row{std::to_string(++ordinal)};
    for (std::uint32_t a : c.port_address) row.push_back(a < n ? std::to_string(a) : "");
    for (const SlotComparison& s : c.comparisons) {
      row.push_back(s.valid ? pair_text(s.anchor, s.partner) : std::string());
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

TableRows many_object_table(const ManyObjectTrace& trace, std::uint32_t n) {
  TableRows rows;
  if (trace.empty()) return rows;
  const auto m = static_cast<std::uint32_t>(trace.front().selector.size());
  std::vector<std::string> header{"Cycle"};
  for (int block = 0; block < 4; ++block) {
    for (std::uint32_t j = 0; j < m; ++j) header.push_back(port_name(j, block < 2 ? 'A' : 'B'));
  }
  for (std::uint32_t j = 0; j < m; ++j) header.push_back(std::to_string(j));
  rows.push_back(std::move(header));
  std::uint32_t ordinal = 0;
  for (const ManyObjectCycle& c : trace) {
    std::vector<std::string> row{std::to_string(++ordinal)};
    for (std::uint32_t a : c.a_address) row.push_back(std::to_string(a));
    for (std::uint32_t j = 0; j < m; ++j) {
      const std::uint32_t object = c.a_object[j];
      row.push_back(marked_object(object + 1 < n, object, comparator_mark(j, m)));
    }
    for (std::uint32_t b : c.b_address) row.push_back(std::to_string(b));
    // B group j feeds the comparator whose selector names j.
    std::vector<std::uint32_t> reader(m, 0);
    for (std::uint32_t comp = 0; comp < m; ++comp) reader[c.selector[comp]] = comp;
    for (std::uint32_t j = 0; j < m; ++j) {
      const std::uint32_t object = c.b_object[j];
      row.push_back(marked_object(object < n, object, comparator_mark(reader[j], m)));
    }
    for (std::uint32_t s : c.selector) row.push_back(std::to_string(s));
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string to_tsv(const TableRows& rows) {
  std::string out;
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (i > 0) out += '\t';
      out += row[i];
    }
    out += '\n';
  }
  return out;
}

}  // namespace hbp::hw
