// SPDX-License-Identifier: MIT
// The task systems the library ships (hbp/task_system.hpp): serial, and
// oneTBB's (an arena of its own).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "hbp/task_system.hpp"
#include "pipeline/arena_threads.hpp"

namespace hbp {

void SerialTaskSystem::run(std::uint32_t task_count, TaskFunction fn, void* context) {
  for (std::uint32_t i = 0; i < task_count; ++i) fn(context, i);
}

struct TbbTaskSystem::Arena {
  explicit Arena(unsigned threads) : arena(detail::arena_threads(threads)) {}
  tbb::task_arena arena;
};

TbbTaskSystem::TbbTaskSystem(unsigned threads) : arena_(std::make_unique<Arena>(threads)) {}
TbbTaskSystem::~TbbTaskSystem() = default;

void TbbTaskSystem::run(std::uint32_t task_count, TaskFunction fn, void* context) {
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, task_count, 1),
                      [&](const tbb::blocked_range<std::uint32_t>& r) {
                        for (std::uint32_t i = r.begin(); i != r.end(); ++i) fn(context, i);
                      });
  });
}

unsigned TbbTaskSystem::concurrency() const { return static_cast<unsigned>(arena_->arena.max_concurrency()); }

}  // namespace hbp
