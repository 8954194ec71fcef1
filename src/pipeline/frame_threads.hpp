// SPDX-License-Identifier: MIT
#pragma once
// The threads a broad phase runs its calls on: the engine's task system
// (BroadPhaseOptions::task_system) when it lent one, else an own oneTBB
// arena of BroadPhaseOptions::threads threads. execute(f) runs f with the
// library's parallel loops (support/parallel_for.hpp) going there.
#include <tbb/task_arena.h>

#include <algorithm>

#include "hbp/limits.hpp"
#include "hbp/task_system.hpp"
#include "pipeline/arena_threads.hpp"
#include "support/parallel_for.hpp"

namespace hbp::detail {

class FrameThreads {
 public:
  // threads is checked against the limit even when the engine's system is
  // used (the option is then unused: the engine's system has its own).
  FrameThreads(unsigned threads, TaskSystem* tasks) : tasks_(tasks), arena_(arena_threads(threads)) {}

  // f() on these threads: in the arena (entered), or on the calling thread
  // with its loops going to the engine's task system.
  template <class F>
  decltype(auto) execute(F&& f) {
    if (tasks_) {
      UseTaskSystem use(tasks_);
      return f();
    }
    return arena_.execute([&]() -> decltype(auto) {
      UseTaskSystem use(nullptr);
      return f();
    });
  }

  // f() on the calling thread without entering the arena (a frame too small
  // to wake workers); with the engine's system, its loops still go there.
  template <class F>
  decltype(auto) execute_here(F&& f) {
    if (!tasks_) return f();
    UseTaskSystem use(tasks_);
    return f();
  }

  int max_concurrency() const {
    return tasks_ ? static_cast<int>(std::clamp(tasks_->concurrency(), 1u, kMaxThreads)) : arena_.max_concurrency();
  }

 private:
  TaskSystem* tasks_;
  tbb::task_arena arena_;
};

}  // namespace hbp::detail
