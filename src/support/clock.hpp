// SPDX-License-Identifier: MIT
#pragma once
// The library's clocks, written once: wall time on std::chrono::steady_clock
// (monotonic: what a user waits) and the calling thread's CPU time
// (CLOCK_THREAD_CPUTIME_ID: unaffected by other processes on a loaded machine).
// Timings in FrameStats, the tools and the benchmarks all read these.
#include <time.h>

#include <chrono>

namespace hbp {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds of wall time since `start`.
inline double ms_since(SteadyClock::time_point start) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
}

// Seconds of wall time since `start`.
inline double seconds_since(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

// CPU time of the calling thread, in milliseconds (differences are meaningful).
inline double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

}  // namespace hbp
