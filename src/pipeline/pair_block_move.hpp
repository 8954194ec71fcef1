// SPDX-License-Identifier: MIT
#pragma once
// Moves a block of a pair list within the list, on all workers of the
// calling arena: the back lane's block is half of a dense frame's list
// (~250 MB on clustered 1,000,000), moved by the change in pair count,
// which is small on a steady frame.
#include <cstddef>

#include "hbp/pair.hpp"
#include "partition/raw_buffer.hpp"

namespace hbp::detail {

// Moves count pairs of `base` from index `from` to index `to` (the ranges
// may overlap). serial: on the calling thread (one memmove); else in
// `chunks` pieces per step, setting pairs aside in `scratch`.
void move_pair_block(Pair* base, std::size_t from, std::size_t to, std::size_t count, bool serial,
                     std::size_t chunks, RawBuffer<Pair>& scratch);

}  // namespace hbp::detail
