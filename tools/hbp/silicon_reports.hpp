// SPDX-License-Identifier: MIT
#pragma once
// The standard-cell flow's stored outputs, as `hbp hw asic|energy` read them:
// one report per design and m (rtl/synth/asic.sh) and the activity file the
// flow was given (`hbp hw activity`), both in one folder (default
// docs/results/asic).
#include <map>
#include <string>
#include <vector>

#include "hbp/hw/asic_report.hpp"
#include "hbp/hw/silicon_estimate.hpp"

namespace hbp::cli {

inline const char* kDefaultAsicReports = "docs/results/asic";

struct SiliconReports {
  std::vector<hw::AsicReport> reports;  // area-efficient first, then by m
  std::map<std::string, double> activity;  // the activity file's keys
  // The measured per-cycle activity of a design ("ae" / "mo" keys).
  hw::CycleActivity cycle_activity(hw::Design d) const;
};

// Throws InvalidInput naming the folder or file when there is nothing to read.
SiliconReports read_silicon_reports(const std::string& folder);

// "key = value" lines (# comments), as the activity file is written.
std::map<std::string, double> parse_key_values(const std::string& text, const std::string& name);

}  // namespace hbp::cli
