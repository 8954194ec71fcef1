// SPDX-License-Identifier: MIT
#pragma once
// The device-wide primitives the GPU paths use (CUB, instantiated once in
// device_primitives.cu): stable radix sorts and scans, their temporary
// storage in a caller-kept buffer. Each returns whether it grew `temp`.
#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_support.cuh"

namespace hbp::cuda {

// Stable sort of (keys, ids) by bits [0, end_bit) of the keys; the sorted
// data ends in *keys_out / *ids_out (the inputs or the alternates).
bool sort_pairs(std::uint64_t* keys, std::uint64_t* keys_alt, std::uint32_t* ids, std::uint32_t* ids_alt,
                std::uint32_t n, int end_bit, DeviceBuffer& temp, std::uint64_t** keys_out, std::uint32_t** ids_out,
                cudaStream_t s);
bool sort_pairs(std::uint32_t* keys, std::uint32_t* keys_alt, std::uint32_t* ids, std::uint32_t* ids_alt,
                std::uint32_t n, int end_bit, DeviceBuffer& temp, std::uint32_t** keys_out, std::uint32_t** ids_out,
                cudaStream_t s);
// Sort of 64-bit keys by bits [0, end_bit); the sorted keys end in *out
// (keys or keys_alt).
bool sort_keys(std::uint64_t* keys, std::uint64_t* keys_alt, std::uint64_t n, int end_bit, DeviceBuffer& temp,
               std::uint64_t** out, cudaStream_t s);
// Sorts each of `segments` segments of 64-bit keys, segment i being
// [starts[i], starts[i + 1]) of `in`, into the same places of `out`.
bool segmented_sort_keys(const std::uint64_t* in, std::uint64_t* out, std::uint64_t n, std::uint64_t segments,
                         const std::uint64_t* starts, DeviceBuffer& temp, cudaStream_t s);
// out[0] = 0, out[1 + i] = in[0] + ... + in[i] (n + 1 entries).
bool inclusive_sum(const std::uint32_t* in, std::uint32_t* out, std::uint64_t n, DeviceBuffer& temp, cudaStream_t s);
bool inclusive_sum(const std::uint64_t* in, std::uint64_t* out, std::uint64_t n, DeviceBuffer& temp, cudaStream_t s);

}  // namespace hbp::cuda
