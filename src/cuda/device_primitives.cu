// SPDX-License-Identifier: MIT
#include "cuda/device_primitives.cuh"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_segmented_sort.cuh>

namespace hbp::cuda {

namespace {
template <class Key>
bool sort_pairs_of(Key* keys, Key* keys_alt, std::uint32_t* ids, std::uint32_t* ids_alt, std::uint32_t n,
                   int end_bit, DeviceBuffer& temp, Key** keys_out, std::uint32_t** ids_out, cudaStream_t s) {
  cub::DoubleBuffer<Key> k(keys, keys_alt);
  cub::DoubleBuffer<std::uint32_t> v(ids, ids_alt);
  bool grew = false;
  if (n) {
    std::size_t bytes = 0;
    check_cuda(cub::DeviceRadixSort::SortPairs(nullptr, bytes, k, v, n, 0, end_bit, s), "sort size");
    grew = temp.reserve(bytes, false);
    check_cuda(cub::DeviceRadixSort::SortPairs(temp.as<void>(), bytes, k, v, n, 0, end_bit, s), "sort pairs");
  }
  *keys_out = k.Current();
  *ids_out = v.Current();
  return grew;
}
}  // namespace

bool sort_pairs(std::uint64_t* keys, std::uint64_t* keys_alt, std::uint32_t* ids, std::uint32_t* ids_alt,
                std::uint32_t n, int end_bit, DeviceBuffer& temp, std::uint64_t** keys_out, std::uint32_t** ids_out,
                cudaStream_t s) {
  return sort_pairs_of(keys, keys_alt, ids, ids_alt, n, end_bit, temp, keys_out, ids_out, s);
}

bool sort_pairs(std::uint32_t* keys, std::uint32_t* keys_alt, std::uint32_t* ids, std::uint32_t* ids_alt,
                std::uint32_t n, int end_bit, DeviceBuffer& temp, std::uint32_t** keys_out, std::uint32_t** ids_out,
                cudaStream_t s) {
  return sort_pairs_of(keys, keys_alt, ids, ids_alt, n, end_bit, temp, keys_out, ids_out, s);
}

bool sort_keys(std::uint64_t* keys, std::uint64_t* keys_alt, std::uint64_t n, int end_bit, DeviceBuffer& temp,
               std::uint64_t** out, cudaStream_t s) {
  cub::DoubleBuffer<std::uint64_t> k(keys, keys_alt);
  bool grew = false;
  if (n) {
    std::size_t bytes = 0;
    check_cuda(cub::DeviceRadixSort::SortKeys(nullptr, bytes, k, n, 0, end_bit, s), "sort size");
    grew = temp.reserve(bytes, false);
    check_cuda(cub::DeviceRadixSort::SortKeys(temp.as<void>(), bytes, k, n, 0, end_bit, s), "sort keys");
  }
  *out = k.Current();
  return grew;
}

bool segmented_sort_keys(const std::uint64_t* in, std::uint64_t* out, std::uint64_t n, std::uint64_t segments,
                         const std::uint64_t* starts, DeviceBuffer& temp, cudaStream_t s) {
  if (!n) return false;
  const auto items = static_cast<std::int64_t>(n), count = static_cast<std::int64_t>(segments);
  std::size_t bytes = 0;
  check_cuda(cub::DeviceSegmentedSort::SortKeys(nullptr, bytes, in, out, items, count, starts, starts + 1, s),
             "segmented sort size");
  const bool grew = temp.reserve(bytes, false);
  check_cuda(cub::DeviceSegmentedSort::SortKeys(temp.as<void>(), bytes, in, out, items, count, starts, starts + 1, s),
             "segmented sort");
  return grew;
}

namespace {
template <class T>
bool scan(const T* in, T* out, std::uint64_t n, DeviceBuffer& temp, cudaStream_t s) {
  check_cuda(cudaMemsetAsync(out, 0, sizeof(T), s), "scan init");
  if (!n) return false;
  std::size_t bytes = 0;
  check_cuda(cub::DeviceScan::InclusiveSum(nullptr, bytes, in, out + 1, static_cast<std::int64_t>(n), s), "scan size");
  const bool grew = temp.reserve(bytes, false);
  check_cuda(cub::DeviceScan::InclusiveSum(temp.as<void>(), bytes, in, out + 1, static_cast<std::int64_t>(n), s), "scan");
  return grew;
}
}  // namespace

bool inclusive_sum(const std::uint32_t* in, std::uint32_t* out, std::uint64_t n, DeviceBuffer& temp, cudaStream_t s) {
  return scan(in, out, n, temp, s);
}
bool inclusive_sum(const std::uint64_t* in, std::uint64_t* out, std::uint64_t n, DeviceBuffer& temp, cudaStream_t s) {
  return scan(in, out, n, temp, s);
}

}  // namespace hbp::cuda
