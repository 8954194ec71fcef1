// SPDX-License-Identifier: MIT
#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "duration_text.hpp"

namespace hbp::cli {

namespace {

constexpr double kFirstDrawAfterS = 0.5;  // no bar at all for short operations
constexpr double kRedrawEveryS = 0.1;
constexpr int kBarWidth = 30;

}  // namespace

ProgressBar::ProgressBar(std::string label, std::uint64_t total, std::string unit)
    : ProgressBar(std::move(label), total, std::move(unit), stderr, ::isatty(::fileno(stderr)) == 1) {}

ProgressBar::ProgressBar(std::string label, std::uint64_t total, std::string unit, std::FILE* out, bool enabled)
    : label_(std::move(label)),
      unit_(std::move(unit)),
      total_(total),
      out_(out),
      enabled_(enabled),
      start_(Clock::now()),
      last_draw_(start_) {}

ProgressBar::~ProgressBar() { finish(); }

std::string ProgressBar::render(double elapsed_s) const {
  const double fraction = total_ == 0 ? 1.0 : static_cast<double>(done_) / static_cast<double>(total_);
  const int filled = static_cast<int>(fraction * kBarWidth);
  std::string line = label_ + " [";
  line.append(static_cast<std::size_t>(filled), '#');
  line.append(static_cast<std::size_t>(kBarWidth - filled), '.');
  char buf[160];
  const double rate = elapsed_s > 0 ? static_cast<double>(done_) / elapsed_s : 0.0;
  const double eta = rate > 0 ? static_cast<double>(total_ - done_) / rate : -1.0;
  std::snprintf(buf, sizeof buf, "] %3d%% %llu/%llu%s%s  %.1f/s  %s %s", static_cast<int>(fraction * 100.0),
                static_cast<unsigned long long>(done_), static_cast<unsigned long long>(total_),
                unit_.empty() ? "" : " ", unit_.c_str(), rate, done_ >= total_ ? "took" : "ETA",
                format_duration(done_ >= total_ ? elapsed_s : eta, DurationStyle::Clock).c_str());
  return line + buf;
}

void ProgressBar::update(std::uint64_t done) {
  done_ = std::min(done, total_);
  if (!enabled_ || finished_) return;
  const auto now = Clock::now();
  const double since_start = std::chrono::duration<double>(now - start_).count();
  const double since_draw = std::chrono::duration<double>(now - last_draw_).count();
  if (since_start < kFirstDrawAfterS) return;
  if (drawn_ && since_draw < kRedrawEveryS && done_ < total_) return;
  draw(now);
}

void ProgressBar::draw(Clock::time_point now) {
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  // \r returns to the line start; \033[K clears what a longer line left.
  std::fprintf(out_, "\r%s\033[K", render(elapsed).c_str());
  std::fflush(out_);
  drawn_ = true;
  last_draw_ = now;
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  if (!enabled_ || !drawn_) return;  // nothing on screen to complete
  draw(Clock::now());
  std::fputc('\n', out_);
  std::fflush(out_);
}

}  // namespace hbp::cli
