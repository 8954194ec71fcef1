// SPDX-License-Identifier: MIT
#pragma once
// Peak memory per bench system, measured in-process from the kernel's
// resident-set counters (/proc/self/status VmRSS, VmHWM; the peak is reset
// through /proc/self/clear_refs): around each of a system's calls (setup,
// every frame) we record how much its call grew the resident set at its
// peak, and keep the system's own retained growth between calls. The
// system's peak = max over its calls of (retained so far + the call's peak
// growth). Memory the allocator reuses from pages another system freed is
// not seen, so this is a lower bound; glibc's free pages are returned with
// malloc_trim before each setup to keep that small.
#include <cstdint>

namespace hbp::cli {

// Resident set now and its peak since the last reset, in bytes (0 if the
// kernel does not provide them).
struct ResidentSet {
  std::uint64_t rss = 0, hwm = 0;
};
ResidentSet read_resident_set();
// Resets the peak (VmHWM) to the current resident set; false if the kernel
// does not allow it (then peaks are not measured).
bool reset_resident_peak();
// Returns free heap pages to the kernel (glibc malloc_trim).
void trim_heap();

class MemoryMeter {
 public:
  // Call before a system's call: resets the kernel's peak.
  void before();
  // Call after it: accounts the growth to this system.
  void after();
  void reset() { *this = MemoryMeter(); }
  // Peak bytes attributed to the system (0 if not measurable).
  std::uint64_t peak_bytes() const { return peak_ > 0 ? static_cast<std::uint64_t>(peak_) : 0; }
  bool measured() const { return ok_; }

 private:
  std::int64_t retained_ = 0, peak_ = 0;
  std::uint64_t rss_before_ = 0;
  bool ok_ = true, armed_ = false;
};

}  // namespace hbp::cli
