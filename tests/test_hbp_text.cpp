// SPDX-License-Identifier: MIT
// `hbp`'s text formats: CSV fields (tools/hbp/csv.hpp) against RFC 4180
// (quotes doubled, commas and line breaks kept inside the quotes, every field
// read back unchanged by an independent RFC 4180 reader) and durations
// (tools/hbp/duration_text.hpp) in both presentations.
#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

#include "csv.hpp"
#include "duration_text.hpp"

namespace {

using hbp::cli::csv_field;
using hbp::cli::DurationStyle;
using hbp::cli::format_duration;

// RFC 4180 section 2: records end in CRLF or LF, fields split on commas,
// a quoted field may hold commas, CR, LF and "" (one quote).
std::vector<std::vector<std::string>> parse_csv(const std::string& text) {
  std::vector<std::vector<std::string>> records(1);
  std::string field;
  bool quoted = false, was_quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c != '"') field += c;
      else if (i + 1 < text.size() && text[i + 1] == '"') field += text[++i];
      else quoted = false;
    } else if (c == '"') {
      EXPECT_TRUE(field.empty() && !was_quoted) << "quote inside an unquoted field at " << i;
      quoted = was_quoted = true;
    } else if (c == ',') {
      records.back().push_back(field);
      field.clear();
      was_quoted = false;
    } else if (c == '\n' || (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n')) {
      if (c == '\r') ++i;
      records.back().push_back(field);
      field.clear();
      was_quoted = false;
      records.emplace_back();
    } else {
      EXPECT_FALSE(was_quoted) << "text after a closing quote at " << i;
      field += c;
    }
  }
  EXPECT_FALSE(quoted) << "unterminated quoted field";
  if (!field.empty() || was_quoted || !records.back().empty()) records.back().push_back(field);
  if (records.back().empty()) records.pop_back();
  return records;
}

TEST(CsvField, QuotesAndDoublesEmbeddedQuotes) {
  EXPECT_EQ(csv_field(""), "\"\"");
  EXPECT_EQ(csv_field("hybrid sw (m)"), "\"hybrid sw (m)\"");
  EXPECT_EQ(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_field("\""), "\"\"\"\"");
  EXPECT_EQ(csv_field("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_field("line 1\nline 2\r\n"), "\"line 1\nline 2\r\n\"");
}

TEST(CsvField, EveryFieldReadsBackUnchanged) {
  const std::vector<std::string> fields = {"plain",     "",         "comma, inside", "\"quoted\"",
                                           "a \"\" b",  "new\nline", "crlf\r\nend",  "trailing \"",
                                           ",\",\n\",", "x"};
  std::string row;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i > 0) row += ',';
    row += csv_field(fields[i]);
  }
  std::string text = "a,b\n";  // appended piecewise: GCC 12 warns falsely on "literal" + string at -O3
  text.append(row).append("\n").append(row).append("\r\n");
  const auto records = parse_csv(text);
  ASSERT_EQ(records.size(), 3u) << text;
  EXPECT_EQ(records[0], (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(records[1], fields);
  EXPECT_EQ(records[2], fields);
}

TEST(Duration, WordsForReports) {
  EXPECT_EQ(format_duration(0), "0 s");
  EXPECT_EQ(format_duration(45.4), "45 s");
  EXPECT_EQ(format_duration(89.4), "89 s");
  EXPECT_EQ(format_duration(90), "2 min");
  EXPECT_EQ(format_duration(31 * 60 + 10), "31 min");
  EXPECT_EQ(format_duration(5399), "90 min");
  EXPECT_EQ(format_duration(5400), "1.5 h");
  EXPECT_EQ(format_duration(2.1 * 3600), "2.1 h");
}

TEST(Duration, ClockForTheProgressBar) {
  EXPECT_EQ(format_duration(0, DurationStyle::Clock), "0:00");
  EXPECT_EQ(format_duration(44.6, DurationStyle::Clock), "0:45");
  EXPECT_EQ(format_duration(31 * 60 + 2, DurationStyle::Clock), "31:02");
  EXPECT_EQ(format_duration(3599.4, DurationStyle::Clock), "59:59");
  EXPECT_EQ(format_duration(3599.6, DurationStyle::Clock), "1:00:00");
  EXPECT_EQ(format_duration(2 * 3600 + 5 * 60 + 7, DurationStyle::Clock), "2:05:07");
  EXPECT_EQ(format_duration(-1, DurationStyle::Clock), "--:--");
  EXPECT_EQ(format_duration(std::numeric_limits<double>::infinity(), DurationStyle::Clock), "--:--");
  EXPECT_EQ(format_duration(std::numeric_limits<double>::quiet_NaN(), DurationStyle::Clock), "--:--");
}

}  // namespace
