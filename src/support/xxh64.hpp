// SPDX-License-Identifier: MIT
#pragma once
// XXH64 (seed 0) of a byte range: the checksum of BroadPhase snapshots.
// The published algorithm, from Debian's xxHash (libxxhash-dev), inlined
// here so the core library adds no link dependency; any xxHash
// implementation checks a snapshot.
#include <cstddef>
#include <cstdint>

#define XXH_INLINE_ALL
#include <xxhash.h>

namespace hbp::detail {

inline std::uint64_t xxh64(const void* data, std::size_t size) { return XXH64(data, size, 0); }

}  // namespace hbp::detail
