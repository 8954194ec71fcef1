// SPDX-License-Identifier: MIT
// The models against the paper's worked examples (Tables 1-3, m = 4, n = 10)
// and its sequence-length formulas.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp/benchdata/paper_table4.hpp"
#include "hbp/hw/resources.hpp"
#include "hbp/benchdata/paper_tables.hpp"

namespace {

using hbp::hw::TableRows;

// Table rows as printed in the paper (tab-separated, blanks kept).
const char* const kPaperTable1 =
    "\t0A\t0B\t1A\t1B\t2A\t2B\t3A\t3B\t0-1\t0-2\t0-3\t0-4\t0-5\t0-6\t0-7\n"
    "1\t0\t1\t2\t3\t4\t5\t6\t7\t0-1\t0-2\t0-3\t0-4\t0-5\t0-6\t0-7\n"
    "2\t0\t8\t9\t\t\t\t\t\t0-8\t0-9\t\t\t\t\t\n"
    "3\t1\t2\t3\t4\t5\t6\t7\t8\t1-2\t1-3\t1-4\t1-5\t1-6\t1-7\t1-8\n"
    "4\t1\t9\t\t\t\t\t\t\t1-9\t\t\t\t\t\t\n"
    "5\t2\t3\t4\t5\t6\t7\t8\t9\t2-3\t2-4\t2-5\t2-6\t2-7\t2-8\t2-9\n"
    "6\t3\t4\t5\t6\t7\t8\t9\t\t3-4\t3-5\t3-6\t3-7\t3-8\t3-9\t\n"
    "7\t4\t5\t6\t7\t8\t9\t\t\t4-5\t4-6\t4-7\t4-8\t4-9\t\t\n"
    "8\t5\t6\t7\t8\t9\t\t\t\t5-6\t5-7\t5-8\t5-9\t\t\t\n"
    "9\t6\t7\t8\t9\t\t\t\t\t6-7\t6-8\t6-9\t\t\t\t\n"
    "10\t7\t8\t9\t\t\t\t\t\t7-8\t7-9\t\t\t\t\t\n"
    "11\t8\t9\t\t\t\t\t\t\t8-9\t\t\t\t\t\t\n";

const char* const kPaperTable3 =
    "\t0A\t1A\t2A\t3A\t0A\t1A\t2A\t3A\t0B\t1B\t2B\t3B\t0B\t1B\t2B\t3B\t0\t1\t2\t3\n"
    "1\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t1\t0\t0\t0\t4§\t1*\t2†\t3‡\t1\t2\t3\t0\n"
    "2\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t1\t1\t0\t0\t4‡\t5§\t2*\t3†\t2\t3\t0\t1\n"
    "3\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t1\t1\t1\t0\t4†\t5‡\t6§\t3*\t3\t0\t1\t2\n"
    "4\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t1\t1\t1\t1\t4*\t5†\t6‡\t7§\t0\t1\t2\t3\n"
    "5\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t2\t1\t1\t1\t8§\t5*\t6†\t7‡\t1\t2\t3\t0\n"
    "6\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t2\t2\t1\t1\t8‡\t9§\t6*\t7†\t2\t3\t0\t1\n"
    "7\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t2\t2\t2\t1\t8†\t9‡\t§\t7*\t3\t0\t1\t2\n"
    "8\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t2\t2\t2\t2\t8*\t9†\t‡\t§\t0\t1\t2\t3\n"
    "9\t0\t0\t0\t0\t0*\t1†\t2‡\t3§\t3\t2\t2\t2\t§\t9*\t†\t‡\t1\t2\t3\t0\n"
    "10\t1\t1\t1\t1\t4*\t5†\t6‡\t7§\t2\t1\t1\t1\t8§\t5*\t6†\t7‡\t1\t2\t3\t0\n"
    "11\t1\t1\t1\t1\t4*\t5†\t6‡\t7§\t2\t2\t1\t1\t8‡\t9§\t6*\t7†\t2\t3\t0\t1\n"
    "12\t1\t1\t1\t1\t4*\t5†\t6‡\t7§\t2\t2\t2\t1\t8†\t9‡\t§\t7*\t3\t0\t1\t2\n"
    "13\t1\t1\t1\t1\t4*\t5†\t6‡\t7§\t2\t2\t2\t2\t8*\t9†\t‡\t§\t0\t1\t2\t3\n"
    "14\t1\t1\t1\t1\t4*\t5†\t6‡\t7§\t3\t2\t2\t2\t§\t9*\t†\t‡\t1\t2\t3\t0\n"
    "15\t2\t2\t2\t2\t8*\t†\t‡\t§\t3\t2\t2\t2\t§\t9*\t†\t‡\t1\t2\t3\t0\n";

TableRows parse_tsv(const std::string& text) {
  TableRows rows;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::vector<std::string> cells;
    std::size_t start = 0;
    for (;;) {
      const std::size_t tab = line.find('\t', start);
      cells.push_back(line.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
    rows.push_back(std::move(cells));
  }
  return rows;
}

// Ten disjoint unit boxes: the sequence does not depend on the data.
hbp::BoxArray ten_boxes() {
  hbp::BoxArray boxes;
  for (int i = 0; i < 10; ++i) {
    const float x = 3.0f * static_cast<float>(i);
    boxes.push_back({{x, 0, 0}, {x + 1, 1, 1}});
  }
  return boxes;
}

void expect_same_table(const TableRows& paper, const TableRows& model) {
  ASSERT_EQ(paper.size(), model.size());
  // Header: the paper's second header line names the columns after "Cycle".
  for (std::size_t c = 1; c < paper[0].size(); ++c) EXPECT_EQ(paper[0][c], model[0][c]) << "column " << c;
  for (std::size_t r = 1; r < paper.size(); ++r) {
    ASSERT_EQ(paper[r].size(), model[r].size()) << "row " << r;
    for (std::size_t c = 0; c < paper[r].size(); ++c) {
      EXPECT_EQ(paper[r][c], model[r][c]) << "cycle " << r << " column " << model[0][c];
    }
  }
}

hbp::hw::ModelConfig paper_example_config() {
  hbp::hw::ModelConfig cfg;
  cfg.m = 4;
  return cfg;
}

TEST(HwPaperSequences, AreaEfficientReproducesTable1) {
  hbp::hw::AreaEfficientModel model(paper_example_config());
  std::vector<hbp::Pair> pairs;
  hbp::hw::AreaEfficientTrace trace;
  const hbp::hw::Counters k = model.run(ten_boxes(), pairs, &trace);
  EXPECT_EQ(k.cycles.sequence, 11u);
  ASSERT_EQ(trace.size(), 11u);
  expect_same_table(parse_tsv(kPaperTable1), hbp::hw::area_efficient_table(trace, 10));
  // 45 pairs over 11 cycles of 7 slots.
  EXPECT_EQ(k.comparator_slots, 77u);
  EXPECT_EQ(k.comparisons_performed, 45u);
  EXPECT_EQ(k.comparisons_discarded, 32u);
  EXPECT_NEAR(k.utilisation(), 45.0 / 77.0, 1e-12);
  EXPECT_EQ(k.pairs_written, 0u);
}

TEST(HwPaperSequences, ManyObjectReproducesTable3) {
  hbp::hw::ManyObjectModel model(paper_example_config());
  std::vector<hbp::Pair> pairs;
  hbp::hw::ManyObjectTrace trace;
  const hbp::hw::Counters k = model.run(ten_boxes(), pairs, &trace);
  EXPECT_EQ(k.cycles.sequence, 15u);
  ASSERT_EQ(trace.size(), 15u);
  expect_same_table(parse_tsv(kPaperTable3), hbp::hw::many_object_table(trace, 10));
  EXPECT_EQ(k.comparator_slots, 60u);
  EXPECT_EQ(k.comparisons_performed, 45u);
  EXPECT_EQ(k.comparisons_discarded, 15u);
}

TEST(HwPaperSequences, ManyObjectTraceComparisonsFollowTheSelectors) {
  hbp::hw::ManyObjectModel model(paper_example_config());
  std::vector<hbp::Pair> pairs;
  hbp::hw::ManyObjectTrace trace;
  model.run(ten_boxes(), pairs, &trace);
  // Table 3, cycle 7: 0-7, 1-8, 2-9 kept, 3-10 discarded.
  const auto& c7 = trace[6].comparisons;
  EXPECT_EQ(c7[0].anchor, 0u);
  EXPECT_EQ(c7[0].partner, 7u);
  EXPECT_EQ(c7[2].partner, 9u);
  EXPECT_TRUE(c7[2].valid);
  EXPECT_EQ(c7[3].partner, 10u);
  EXPECT_FALSE(c7[3].valid);
  // Every pair i < j appears in exactly one kept slot.
  std::vector<int> seen(100, 0);
  for (const auto& c : trace) {
    for (const auto& s : c.comparisons) {
      if (!s.valid) continue;
      ASSERT_LT(s.anchor, s.partner);
      ++seen[s.anchor * 10 + s.partner];
    }
  }
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) EXPECT_EQ(seen[i * 10 + j], i < j ? 1 : 0) << i << "-" << j;
  }
}

TEST(HwPaperSequences, ManyObjectLayoutIsTable2) {
  hbp::hw::ManyObjectModel model(paper_example_config());
  std::vector<hbp::Pair> pairs;
  hbp::BoxArray boxes = ten_boxes();
  model.run(boxes, pairs);
  // Object a*m + j at address a of group j: its min x is 3 * (a*m + j).
  for (std::uint32_t a = 0; a < 3; ++a) {
    for (std::uint32_t j = 0; j < 4; ++j) {
      const std::uint32_t object = a * 4 + j;
      if (object >= 10) continue;
      EXPECT_EQ(model.buffer().word(hbp::hw::min_coordinate(0), j, a),
                hbp::hw::f32_bits(3.0f * static_cast<float>(object)));
    }
  }
}

TEST(HwPaperSequences, AreaEfficientReplicatesEveryObjectInEveryGroup) {
  hbp::hw::AreaEfficientModel model(paper_example_config());
  std::vector<hbp::Pair> pairs;
  model.run(ten_boxes(), pairs);
  for (std::uint32_t g = 0; g < 4; ++g) {
    for (std::uint32_t a = 0; a < 10; ++a) {
      EXPECT_EQ(model.buffer().word(hbp::hw::max_coordinate(0), g, a),
                hbp::hw::f32_bits(3.0f * static_cast<float>(a) + 1.0f));
    }
  }
}

// The paper's sums written out term by term, as printed.
std::uint64_t paper_area_efficient_sum(std::uint64_t n, std::uint64_t m) {
  std::uint64_t s = 0;
  for (std::uint64_t i = 0; i + 2 <= n; ++i) s += (n - i - 1 + 2 * m - 2) / (2 * m - 1);
  return s;
}
std::uint64_t paper_many_object_sum(std::uint64_t n, std::uint64_t m) {
  std::uint64_t s = 0;
  for (std::uint64_t i = 0; i < (n + m - 1) / m; ++i) s += n - i * m - 1;
  return s;
}

TEST(HwPaperSequences, ClosedFormsEqualThePaperSums) {
  for (std::uint32_t m = 1; m <= 64; ++m) {
    for (std::uint64_t n : {0u, 1u, 2u, 3u, 10u, 31u, 32u, 33u, 100u, 127u, 1000u, 1024u, 4097u,
                            16384u, 65536u}) {
      EXPECT_EQ(hbp::hw::area_efficient_sequence_cycles(n, m), paper_area_efficient_sum(n, m))
          << "n=" << n << " m=" << m;
      EXPECT_EQ(hbp::hw::many_object_sequence_cycles(n, m), paper_many_object_sum(n, m))
          << "n=" << n << " m=" << m;
    }
  }
  EXPECT_EQ(hbp::hw::area_efficient_sequence_cycles(10, 4), 11u);
  EXPECT_EQ(hbp::hw::many_object_sequence_cycles(10, 4), 15u);
  // m = 16 figures used in the Table 4 comparison.
  EXPECT_EQ(hbp::hw::area_efficient_sequence_cycles(1000, 16), 16599u);
  EXPECT_EQ(hbp::hw::many_object_sequence_cycles(16000, 16), 8007000u);
}

TEST(HwPaperSequences, ModelledTimesAgreeWithTable4) {
  const hbp::hw::ModelConfig cfg;  // m = 16, 500 MHz
  int checked = 0;
  for (const hbp::hw::PaperTable4Row& row : hbp::hw::paper_table4()) {
    const auto ms = [&](hbp::hw::Design d) {
      return static_cast<double>(hbp::hw::analytic_cycles(d, row.n, cfg).total()) / cfg.clock_hz * 1e3;
    };
    if (row.area_efficient_none && row.n >= 300) {
      const double ratio = ms(hbp::hw::Design::AreaEfficient) / *row.area_efficient_none;
      EXPECT_GE(ratio, 0.95) << "area-efficient n=" << row.n;
      EXPECT_LE(ratio, 1.05) << "area-efficient n=" << row.n;
      ++checked;
    }
    if (row.many_object_none && row.n >= 300) {
      const double ratio = ms(hbp::hw::Design::ManyObject) / *row.many_object_none;
      EXPECT_GE(ratio, 0.95) << "many-object n=" << row.n;
      EXPECT_LE(ratio, 1.05) << "many-object n=" << row.n;
      ++checked;
    }
    // With the row-change drain the many-object column is reproduced to the
    // table's four printed decimals.
    if (row.many_object_none && row.n >= 2000) {
      EXPECT_NEAR(ms(hbp::hw::Design::ManyObject), *row.many_object_none, 0.00005) << "n=" << row.n;
    }
  }
  EXPECT_EQ(checked, 8 + 12);
}

TEST(HwPaperSequences, ResourceCountsOfSection3) {
  const hbp::hw::ModelConfig cfg;  // m = 16, depth 1024
  const hbp::hw::Resources ae = hbp::hw::resources(hbp::hw::Design::AreaEfficient, cfg);
  EXPECT_EQ(ae.memories, 96u);
  EXPECT_EQ(ae.read_ports, 192u);
  EXPECT_EQ(ae.memory_bits, 96u * 1024u * 32u);
  EXPECT_EQ(ae.ge_comparators, 6u * 16u - 3u);
  EXPECT_EQ(ae.le_comparators, 6u * 16u - 3u);
  EXPECT_EQ(ae.and_gates, 31u);
  EXPECT_EQ(ae.multiplexers, 0u);
  const hbp::hw::Resources mo = hbp::hw::resources(hbp::hw::Design::ManyObject, cfg);
  EXPECT_EQ(mo.memories, 96u);
  EXPECT_EQ(mo.ge_comparators, 48u);
  EXPECT_EQ(mo.le_comparators, 48u);
  EXPECT_EQ(mo.and_gates, 16u);
  EXPECT_EQ(mo.multiplexers, 96u);
  EXPECT_EQ(mo.multiplexer_inputs, 16u);
}

}  // namespace
