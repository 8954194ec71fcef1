// SPDX-License-Identifier: MIT
#include "hbp/hw/asic_report.hpp"

#include <charconv>
#include <map>
#include <string>

#include "hbp/error.hpp"

namespace hbp::hw {
namespace {

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return std::string(s.substr(b, e - b + 1));
}

class Fields {
 public:
  Fields(std::string_view text, const std::string& name) : name_(name) {
    while (!text.empty()) {
      const auto nl = text.find('\n');
      const std::string_view line = text.substr(0, nl);
      text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
      const auto eq = line.find('=');
      if (trim(line).empty()) continue;
      if (eq == std::string_view::npos) throw InvalidInput(name_ + ": line without '=': " + std::string(line));
      values_[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
    }
  }
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  const std::string& text(const std::string& key) const {
    const auto it = values_.find(key);
    if (it == values_.end() || it->second.empty()) throw InvalidInput(name_ + ": no value for '" + key + "'");
    return it->second;
  }
  double number(const std::string& key) const {
    const std::string& v = text(key);
    double x = 0;
    const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
    if (ec != std::errc{} || p != v.data() + v.size())
      throw InvalidInput(name_ + ": '" + key + "' is not a number: " + v);
    return x;
  }
  std::uint64_t count(const std::string& key) const {
    const std::string& v = text(key);
    std::uint64_t x = 0;
    const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
    if (ec != std::errc{} || p != v.data() + v.size())
      throw InvalidInput(name_ + ": '" + key + "' is not a count: " + v);
    return x;
  }

 private:
  std::string name_;
  std::map<std::string, std::string> values_;
};

}  // namespace

AsicReport parse_asic_report(std::string_view text, const std::string& name) {
  const Fields f(text, name);
  AsicReport r;
  r.design = parse_design(f.text("design"));
  r.m = static_cast<std::uint32_t>(f.count("m"));
  r.depth = static_cast<std::uint32_t>(f.count("depth"));
  r.pair_rows = static_cast<std::uint32_t>(f.count("pair_rows"));
  r.lanes = static_cast<std::uint32_t>(f.count("lanes"));
  r.rtl_sha256 = f.text("rtl_sha256");
  r.logic_area_um2 = f.number("logic_area_um2");
  r.cells = f.count("cells");
  r.flip_flops = f.count("flip_flops");
  r.memories = static_cast<std::uint32_t>(f.count("memories"));
  r.clock_period_ns = f.number("clock_period_ns");
  r.worst_slack_ns = f.number("worst_slack_ns");
  r.critical_path_from = f.has("critical_path_from") ? f.text("critical_path_from") : "?";
  r.critical_path_to = f.has("critical_path_to") ? f.text("critical_path_to") : "?";
  r.power_total_w = f.number("power_total_w");
  r.power_leakage_w = f.number("power_leakage_w");
  r.global_activity = f.number("global_activity");
  r.input_activity = f.number("input_activity");
  if (r.m == 0 || r.depth == 0 || r.logic_area_um2 <= 0 || r.cells == 0 || r.clock_period_ns <= 0 ||
      r.critical_path_ns() <= 0 || r.power_total_w <= 0)
    throw InvalidInput(name + ": implausible report (zero m, depth, area, cells, clock, path or power)");
  return r;
}

}  // namespace hbp::hw
