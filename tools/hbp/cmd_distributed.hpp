// SPDX-License-Identifier: MIT
#pragma once
// `hbp run --distributed` and `hbp pairs --distributed`: the hybrid broad
// phase over MPI ranks (docs/distributed.md), started under mpirun. Without
// MPI in the build these throw InvalidInput saying so.
#include <cstdint>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"
#include "run_request.hpp"

namespace hbp::cli {

// Runs the frames on every rank; rank 0 prints (text or one JSON object).
void run_distributed(const RunRequest& request);

// Every rank holds the whole frame (read from the file); each supplies an id
// block, the distributed broad phase finds the pairs, rank 0 gathers them.
// Returns true on rank 0 (which then holds the sorted pairs in `out`).
bool distributed_pairs(const BoxArray& frame, const std::string& engine, std::uint32_t cell_limit,
                       unsigned threads, std::vector<Pair>& out);

}  // namespace hbp::cli
