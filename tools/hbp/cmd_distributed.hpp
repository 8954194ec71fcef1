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

namespace hbp::cli {

struct DistributedRunRequest {
  std::string scene = "paper";
  std::string in;  // scene file instead of a scenario
  std::uint32_t n = 0;
  std::uint32_t frames = 0;
  std::uint64_t seed = 0;
  std::string engine = "sw";
  std::uint32_t cell_limit = 0;
  unsigned threads = 0;
  bool json = false;
  bool quiet = false;
};
// Runs the frames on every rank; rank 0 prints (text or one JSON object).
void run_distributed(const DistributedRunRequest& request);

// Every rank holds the whole frame (read from the file); each supplies an id
// block, the distributed broad phase finds the pairs, rank 0 gathers them.
// Returns true on rank 0 (which then holds the sorted pairs in `out`).
bool distributed_pairs(const BoxArray& frame, const std::string& engine, std::uint32_t cell_limit,
                       unsigned threads, std::vector<Pair>& out);

}  // namespace hbp::cli
