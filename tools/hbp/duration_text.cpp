// SPDX-License-Identifier: MIT
#include "duration_text.hpp"

#include <cmath>
#include <cstdio>

namespace hbp::cli {

std::string format_duration(double s, DurationStyle style) {
  char buf[32];
  if (style == DurationStyle::Clock) {
    if (!std::isfinite(s) || s < 0) return "--:--";  // e.g. no rate yet for an ETA
    const auto total = static_cast<long long>(s + 0.5);
    if (total >= 3600)
      std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", total / 3600, total / 60 % 60, total % 60);
    else
      std::snprintf(buf, sizeof buf, "%lld:%02lld", total / 60, total % 60);
    return buf;
  }
  if (s < 90) std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 5400) std::snprintf(buf, sizeof buf, "%.0f min", s / 60);
  else std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  return buf;
}

}  // namespace hbp::cli
