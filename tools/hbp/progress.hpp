// SPDX-License-Identifier: MIT
#pragma once
// A one-line progress bar for long `hbp` operations (scene writes, bench
// runs). It draws on stderr only when stderr is a terminal, so pipes, logs
// and CI output stay clean, and only once the operation has run for half a
// second, so short operations never flicker.
//
//   ProgressBar bar("writing", frames, "frames");
//   for (...) { ...; bar.advance(); }
//   bar.finish();
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace hbp::cli {

class ProgressBar {
 public:
  // `out` defaults to stderr; `enabled` defaults to "out is a terminal".
  ProgressBar(std::string label, std::uint64_t total, std::string unit = "");
  ProgressBar(std::string label, std::uint64_t total, std::string unit, std::FILE* out, bool enabled);
  ~ProgressBar();  // finishes the line if finish() was not called
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void update(std::uint64_t done);  // absolute progress, clamped to total
  void advance(std::uint64_t delta = 1) { update(done_ + delta); }
  // Draws the final state (if anything was drawn) and ends the line.
  void finish();

  bool enabled() const { return enabled_; }
  std::uint64_t done() const { return done_; }

  // The line as it would be drawn after `elapsed_s` seconds (for tests).
  std::string render(double elapsed_s) const;

 private:
  using Clock = std::chrono::steady_clock;
  void draw(Clock::time_point now);

  std::string label_, unit_;
  std::uint64_t total_, done_ = 0;
  std::FILE* out_;
  bool enabled_;
  bool drawn_ = false, finished_ = false;
  Clock::time_point start_, last_draw_;
};

}  // namespace hbp::cli
