// SPDX-License-Identifier: MIT
#pragma once
// Stable LSD radix sort of 64-bit keys (with an optional 32-bit payload)
// over the low `bits` bits, in caller-kept scratch: the CPU twin of the
// device's cub::DeviceRadixSort. Both are stable, so equal keys keep their
// input order and the two launchers give the same permutation.
#include <cstdint>
#include <utility>
#include <vector>

namespace hbp::cuda {

inline void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& key_scratch,
                       std::vector<std::uint32_t>* ids, std::vector<std::uint32_t>* id_scratch, int bits) {
  constexpr int kDigit = 11;
  const std::size_t n = keys.size();
  // The scratch takes the keys' capacity, so the swaps below keep both.
  key_scratch.reserve(keys.capacity());
  key_scratch.resize(n);
  if (ids) {
    id_scratch->reserve(ids->capacity());
    id_scratch->resize(n);
  }
  std::uint64_t counts[1u << kDigit];
  for (int shift = 0; shift < bits; shift += kDigit) {
    for (auto& c : counts) c = 0;
    for (std::size_t i = 0; i < n; ++i) ++counts[(keys[i] >> shift) & ((1u << kDigit) - 1)];
    std::uint64_t sum = 0;
    for (auto& c : counts) sum += std::exchange(c, sum);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint64_t slot = counts[(keys[i] >> shift) & ((1u << kDigit) - 1)]++;
      key_scratch[slot] = keys[i];
      if (ids) (*id_scratch)[slot] = (*ids)[i];
    }
    keys.swap(key_scratch);
    if (ids) ids->swap(*id_scratch);
  }
}

}  // namespace hbp::cuda
