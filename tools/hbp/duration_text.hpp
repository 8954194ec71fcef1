// SPDX-License-Identifier: MIT
#pragma once
// How `hbp` writes a duration, in one place. Two presentations of the same
// rounding: words for reports and messages ("45 s", "31 min", "2.1 h"),
// a clock for the progress bar's ETA that ticks every second ("0:45",
// "31:02", "2:05:07"; "--:--" when unknown).
#include <string>

namespace hbp::cli {

enum class DurationStyle {
  Words,  // "45 s" below 90 s, "31 min" below 90 min, then "2.1 h"
  Clock,  // "m:ss", from an hour "h:mm:ss", rounded to the second
};

std::string format_duration(double seconds, DurationStyle style = DurationStyle::Words);

}  // namespace hbp::cli
