// SPDX-License-Identifier: MIT
#include "silicon_reports.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hbp/error.hpp"

namespace hbp::cli {
namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  if (!in) throw InvalidInput("cannot read " + p.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

}  // namespace

std::map<std::string, double> parse_key_values(const std::string& text, const std::string& name) {
  std::map<std::string, double> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const auto eq = t.find('=');
    if (eq == std::string::npos) throw InvalidInput(name + ": line without '=': " + t);
    const std::string key = trim(t.substr(0, eq)), value = trim(t.substr(eq + 1));
    double v = 0;
    const auto [p, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
    if (ec != std::errc{} || p != value.data() + value.size())
      throw InvalidInput(name + ": '" + key + "' is not a number: " + value);
    out[key] = v;
  }
  return out;
}

hw::CycleActivity SiliconReports::cycle_activity(hw::Design d) const {
  const std::string p = d == hw::Design::AreaEfficient ? "ae_" : "mo_";
  auto get = [&](const std::string& k) {
    const auto it = activity.find(p + k);
    if (it == activity.end()) throw InvalidInput("activity file: no value for '" + p + k + "'");
    return it->second;
  };
  hw::CycleActivity a;
  a.load_fraction = get("load_fraction");
  a.sequence_fraction = get("sequence_fraction");
  a.pairs_per_cycle = get("pairs_per_cycle");
  a.datapath_activity = get("global_activity");
  a.input_activity = get("input_activity");
  return a;
}

SiliconReports read_silicon_reports(const std::string& folder) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(folder))
    throw InvalidInput("no flow reports: folder " + folder + " not found (rtl/synth/asic.sh writes them)");
  SiliconReports s;
  s.activity = parse_key_values(read_text(fs::path(folder) / "activities.txt"), folder + "/activities.txt");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder)) {
    const std::string name = e.path().filename().string();
    if ((name.rfind("ae_m", 0) == 0 || name.rfind("mo_m", 0) == 0) && e.path().extension() == ".txt")
      files.push_back(e.path());
  }
  if (files.empty()) throw InvalidInput("no flow reports (ae_m*.txt, mo_m*.txt) in " + folder);
  for (const fs::path& f : files) s.reports.push_back(hw::parse_asic_report(read_text(f), f.string()));
  std::sort(s.reports.begin(), s.reports.end(), [](const hw::AsicReport& a, const hw::AsicReport& b) {
    return a.design != b.design ? a.design == hw::Design::AreaEfficient : a.m < b.m;
  });
  return s;
}

}  // namespace hbp::cli
