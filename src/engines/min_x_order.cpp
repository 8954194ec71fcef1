#include "engines/min_x_order.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

namespace hbp {

bool in_min_x_order(const float* min_x, std::uint32_t n) {
  bool sorted = true;
  // No early exit: a branch-free pass vectorises and the cells are small.
  for (std::uint32_t i = 1; i < n; ++i) sorted &= min_x_key(min_x[i - 1]) <= min_x_key(min_x[i]);
  return sorted;
}

void min_x_order(const float* min_x, std::uint32_t n, std::vector<std::uint32_t>& order,
                 std::vector<std::uint64_t>& scratch) {
  order.resize(n);
  if (scratch.size() < 2 * std::size_t{n}) scratch.resize(2 * std::size_t{n});
  std::uint64_t* a = scratch.data();
  std::uint64_t* b = scratch.data() + n;
  // Bits in which any key differs from the first: bytes without one need no pass.
  const std::uint32_t first = n ? min_x_key(min_x[0]) : 0;
  std::uint32_t differ = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t k = min_x_key(min_x[i]);
    differ |= k ^ first;
    a[i] = (std::uint64_t{k} << 32) | i;
  }
  if (n <= 48) {
    std::sort(a, a + n);
  } else {
    std::uint32_t count[256];
    for (int byte = 0; byte < 4; ++byte) {
      const int shift = 32 + 8 * byte;
      if (((differ >> (8 * byte)) & 0xFF) == 0) continue;
      std::memset(count, 0, sizeof count);
      for (std::uint32_t i = 0; i < n; ++i) ++count[(a[i] >> shift) & 0xFF];
      std::uint32_t sum = 0;
      for (auto& c : count) {
        const std::uint32_t t = c;
        c = sum;
        sum += t;
      }
      for (std::uint32_t i = 0; i < n; ++i) b[count[(a[i] >> shift) & 0xFF]++] = a[i];
      std::swap(a, b);
    }
  }
  for (std::uint32_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(a[i]);
}

}  // namespace hbp
