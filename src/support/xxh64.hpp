// SPDX-License-Identifier: MIT
#pragma once
// XXH64 (seed 0) of a byte range: the checksum of BroadPhase snapshots.
// The published algorithm, so any xxHash implementation checks a snapshot;
// it reads 32 bytes per round in four independent lanes (several GB/s), so a
// snapshot of a million objects is checked in a few milliseconds.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace hbp::detail {

namespace xxh64_detail {
inline constexpr std::uint64_t kP1 = 11400714785074694791ull;
inline constexpr std::uint64_t kP2 = 14029467366897019727ull;
inline constexpr std::uint64_t kP3 = 1609587929392839161ull;
inline constexpr std::uint64_t kP4 = 9650029242287828579ull;
inline constexpr std::uint64_t kP5 = 2870177450012600261ull;

inline std::uint64_t rotl(std::uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
// Little-endian reads (the algorithm's byte order on any host).
inline std::uint64_t read64(const unsigned char* p) {
  std::uint64_t v;
  std::memcpy(&v, p, sizeof v);
  if constexpr (std::endian::native == std::endian::big) v = __builtin_bswap64(v);
  return v;
}
inline std::uint32_t read32(const unsigned char* p) {
  std::uint32_t v;
  std::memcpy(&v, p, sizeof v);
  if constexpr (std::endian::native == std::endian::big) v = __builtin_bswap32(v);
  return v;
}
inline std::uint64_t round(std::uint64_t acc, std::uint64_t input) { return rotl(acc + input * kP2, 31) * kP1; }
inline std::uint64_t merge(std::uint64_t acc, std::uint64_t v) { return (acc ^ round(0, v)) * kP1 + kP4; }
}  // namespace xxh64_detail

inline std::uint64_t xxh64(const void* data, std::size_t size) {
  using namespace xxh64_detail;
  const auto* p = static_cast<const unsigned char*>(data);
  const unsigned char* const end = p + size;
  std::uint64_t h;
  if (size >= 32) {
    std::uint64_t v1 = kP1 + kP2, v2 = kP2, v3 = 0, v4 = 0 - kP1;
    for (; end - p >= 32; p += 32) {
      v1 = round(v1, read64(p));
      v2 = round(v2, read64(p + 8));
      v3 = round(v3, read64(p + 16));
      v4 = round(v4, read64(p + 24));
    }
    h = rotl(v1, 1) + rotl(v2, 7) + rotl(v3, 12) + rotl(v4, 18);
    h = merge(merge(merge(merge(h, v1), v2), v3), v4);
  } else {
    h = kP5;
  }
  h += static_cast<std::uint64_t>(size);
  for (; end - p >= 8; p += 8) h = rotl(h ^ round(0, read64(p)), 27) * kP1 + kP4;
  if (end - p >= 4) {
    h = rotl(h ^ (static_cast<std::uint64_t>(read32(p)) * kP1), 23) * kP2 + kP3;
    p += 4;
  }
  for (; p < end; ++p) h = rotl(h ^ (*p * kP5), 11) * kP1;
  h ^= h >> 33;
  h *= kP2;
  h ^= h >> 29;
  h *= kP3;
  h ^= h >> 32;
  return h;
}

}  // namespace hbp::detail
