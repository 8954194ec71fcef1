// SPDX-License-Identifier: MIT
#pragma once
// The task arena size of BroadPhaseOptions::threads, checked once at
// construction against the one thread limit (hbp/limits.hpp), so that no
// broad phase is ever built on an arena oneTBB cannot tear down.
#include <tbb/task_arena.h>

#include <string>

#include "hbp/error.hpp"
#include "hbp/limits.hpp"

namespace hbp::detail {

inline int arena_threads(unsigned threads) {
  if (threads > kMaxThreads)
    throw InvalidInput("threads: " + std::to_string(threads) + " is more than the limit of " +
                       std::to_string(kMaxThreads) + " (0: all cores)");
  return threads ? static_cast<int>(threads) : tbb::task_arena::automatic;
}

}  // namespace hbp::detail
