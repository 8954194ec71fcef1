// SPDX-License-Identifier: MIT
#pragma once
// The part of oneTBB that the scene generator (src/scene/scenario.cpp) uses,
// for the device machine's standalone build, which has no TBB: a range split
// into one contiguous piece per hardware thread. The generator's work is per
// object, so the boxes are bit-identical to the TBB build's.
#include <algorithm>
#include <cstddef>
#include <thread>
#include <vector>

namespace tbb {

template <class T>
class blocked_range {
 public:
  blocked_range(T begin, T end, std::size_t = 1) : begin_(begin), end_(end) {}
  T begin() const { return begin_; }
  T end() const { return end_; }

 private:
  T begin_, end_;
};

template <class T, class Body>
void parallel_for(const blocked_range<T>& range, const Body& body) {
  const std::size_t n = static_cast<std::size_t>(range.end() - range.begin());
  const std::size_t workers = std::max<std::size_t>(1, std::min<std::size_t>(std::thread::hardware_concurrency(), n / 4096));
  std::vector<std::thread> pool;
  for (std::size_t w = 0; w < workers; ++w) {
    const T lo = range.begin() + static_cast<T>(n * w / workers);
    const T hi = range.begin() + static_cast<T>(n * (w + 1) / workers);
    pool.emplace_back([&body, lo, hi] { body(blocked_range<T>(lo, hi)); });
  }
  for (auto& t : pool) t.join();
}

}  // namespace tbb
