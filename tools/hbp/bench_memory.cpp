// SPDX-License-Identifier: MIT
#include "bench_memory.hpp"

#include <malloc.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace hbp::cli {

ResidentSet read_resident_set() {
  ResidentSet r;
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return r;
  char line[256];
  while (std::fgets(line, sizeof line, f)) {
    unsigned long long kb = 0;
    if (std::sscanf(line, "VmRSS: %llu kB", &kb) == 1) r.rss = kb * 1024;
    else if (std::sscanf(line, "VmHWM: %llu kB", &kb) == 1) r.hwm = kb * 1024;
  }
  std::fclose(f);
  return r;
}

bool reset_resident_peak() {
  std::FILE* f = std::fopen("/proc/self/clear_refs", "w");
  if (!f) return false;
  // "5": reset the peak resident set size (Linux >= 4.0).
  const bool ok = std::fputs("5", f) >= 0;
  return std::fclose(f) == 0 && ok;
}

void trim_heap() { malloc_trim(0); }

void MemoryMeter::before() {
  armed_ = false;
  if (!ok_) return;
  if (!reset_resident_peak()) {
    ok_ = false;
    return;
  }
  rss_before_ = read_resident_set().rss;
  armed_ = rss_before_ > 0;
  if (!armed_) ok_ = false;
}

void MemoryMeter::after() {
  if (!armed_) return;
  armed_ = false;
  const ResidentSet r = read_resident_set();
  const auto base = static_cast<std::int64_t>(rss_before_);
  const std::int64_t call_peak = static_cast<std::int64_t>(std::max(r.hwm, r.rss)) - base;
  peak_ = std::max(peak_, retained_ + call_peak);
  retained_ += static_cast<std::int64_t>(r.rss) - base;
}

}  // namespace hbp::cli
