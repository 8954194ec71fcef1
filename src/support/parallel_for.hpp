// SPDX-License-Identifier: MIT
#pragma once
// The one door of the library's parallel loops: [0, n) cut into fixed
// chunks of `grain` (the last one shorter), handed to the engine's
// TaskSystem (hbp/task_system.hpp) or, by default, to oneTBB's current
// arena. The chunks depend on n and grain only, never on the threads, so a
// body that writes by chunk, and a reduction combined in chunk order, give
// the same result on any task system and thread count.
//
// Which threads: the calling thread's task context, set for the span of a
// broad phase's call (UseTaskSystem below, from pipeline/frame_threads.hpp)
// and carried into every task, so code deep in a frame (the partition, the
// sort) reaches the engine's task system without passing it down.
// A loop inside a task of the engine's task system runs inline on that
// task's thread: the engine is never called nested (its contract says it
// need not support that). Under oneTBB loops nest as oneTBB does.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>

#include "hbp/limits.hpp"
#include "hbp/task_system.hpp"

namespace hbp::detail {

struct TaskContext {
  TaskSystem* tasks = nullptr;  // null: oneTBB's current arena
  bool in_task = false;         // in a task of `tasks`: loops run inline
};

inline TaskContext& task_context() {
  static thread_local TaskContext context;
  return context;
}

// The calling thread's loops go to `tasks` (null: oneTBB) until the scope ends.
class UseTaskSystem {
 public:
  explicit UseTaskSystem(TaskSystem* tasks) : saved_(task_context()) { task_context() = {tasks, false}; }
  ~UseTaskSystem() { task_context() = saved_; }
  UseTaskSystem(const UseTaskSystem&) = delete;
  UseTaskSystem& operator=(const UseTaskSystem&) = delete;

 private:
  TaskContext saved_;
};

// The engine's task system when this thread's loops go to it (and are not
// already inside one of its tasks), else null.
inline TaskSystem* engine_tasks() {
  const TaskContext& c = task_context();
  return c.in_task ? nullptr : c.tasks;
}

// How many chunks can run at once: sizes work splits (never what a loop outputs).
inline int concurrency() {
  const TaskContext& c = task_context();
  if (!c.tasks) return tbb::this_task_arena::max_concurrency();
  if (c.in_task) return 1;
  return static_cast<int>(std::clamp(c.tasks->concurrency(), 1u, kMaxThreads));
}

inline std::size_t chunk_count(std::size_t n, std::size_t grain) { return (n + grain - 1) / grain; }

// Engine tasks a batch of `chunks` chunks is grouped into: consecutive
// chunks a task, enough tasks a thread for balance. The grouping may follow
// the threads: results are written by chunk, not by task.
inline constexpr std::size_t kTasksPerThread = 16;

template <class Body>
struct EngineBatch {
  const Body* body;
  std::size_t n, grain, chunks, tasks;
  TaskSystem* system;
  std::atomic<bool> failed{false};
  std::mutex error_lock;
  std::exception_ptr error;

  // One engine task: its chunks, in the task context of a task (nested
  // loops inline); the first exception is kept and stops the others.
  static void run_task(void* context, std::uint32_t t) {
    auto& b = *static_cast<EngineBatch*>(context);
    if (b.failed.load(std::memory_order_relaxed)) return;
    TaskContext& here = task_context();
    const TaskContext saved = here;
    here = {b.system, true};
    try {
      const std::size_t first = b.chunks * t / b.tasks, last = b.chunks * (t + 1) / b.tasks;
      for (std::size_t k = first; k != last && !b.failed.load(std::memory_order_relaxed); ++k)
        (*b.body)(k * b.grain, std::min(b.n, (k + 1) * b.grain), k);
    } catch (...) {
      std::lock_guard<std::mutex> lock(b.error_lock);
      if (!b.error) b.error = std::current_exception();
      b.failed.store(true, std::memory_order_relaxed);
    }
    here = saved;
  }
};

// body(begin, end, chunk) once for each chunk of [0, n): chunk k is
// [k * grain, min(n, (k + 1) * grain)). Returns when all have run; an
// exception of a body is rethrown here (the remaining chunks may not run).
template <class Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  grain = std::max<std::size_t>(grain, 1);
  const std::size_t chunks = chunk_count(n, grain);
  if (chunks == 0) return;
  const TaskContext& c = task_context();
  if (chunks == 1 || c.in_task) {
    for (std::size_t k = 0; k < chunks; ++k) body(k * grain, std::min(n, (k + 1) * grain), k);
    return;
  }
  if (!c.tasks) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t k = r.begin(); k != r.end(); ++k) body(k * grain, std::min(n, (k + 1) * grain), k);
    });
    return;
  }
  const std::size_t threads = static_cast<std::size_t>(concurrency());
  EngineBatch<Body> batch;
  batch.body = &body;
  batch.n = n;
  batch.grain = grain;
  batch.chunks = chunks;
  batch.tasks = std::min(chunks, kTasksPerThread * threads);
  batch.system = c.tasks;
  c.tasks->run(static_cast<std::uint32_t>(batch.tasks), &EngineBatch<Body>::run_task, &batch);
  if (batch.error) std::rethrow_exception(batch.error);
}

// body(begin, end) over the chunks of [0, n) of `grain` items.
template <class Body>
void parallel_for(std::size_t n, std::size_t grain, const Body& body) {
  parallel_chunks(n, grain, [&](std::size_t begin, std::size_t end, std::size_t) { body(begin, end); });
}

// body(i) for each i in [0, n), one chunk each (n: a few chunks or tasks of
// the caller's own, e.g. lanes or pieces of a copy).
template <class Body>
void parallel_for_each(std::size_t n, const Body& body) {
  parallel_chunks(n, 1, [&](std::size_t i, std::size_t, std::size_t) { body(i); });
}

// f() and g(), possibly at once. Recursive builders nest it: oneTBB runs
// every level in parallel; on the engine's task system the outermost call
// is one batch of two tasks and the levels below run inline in them (no
// nested batches), so such a build uses two of the engine's threads.
template <class F, class G>
void parallel_invoke(const F& f, const G& g) {
  if (!task_context().tasks) {
    tbb::parallel_invoke(f, g);
    return;
  }
  parallel_for_each(2, [&](std::size_t i) { i == 0 ? f() : g(); });
}

// Reduces [0, n): acc = body(begin, end, acc) per chunk, starting from
// `identity`, then the chunks' results combined in chunk order. At most
// kReduceChunks chunks (grain raised for long ranges, by n alone), so the
// partial results live on the stack.
inline constexpr std::size_t kReduceChunks = 64;

template <class T, class Body, class Combine>
T parallel_reduce(std::size_t n, std::size_t grain, const T& identity, const Body& body, const Combine& combine) {
  grain = std::max({grain, std::size_t{1}, chunk_count(n, kReduceChunks)});
  std::array<T, kReduceChunks> partial;
  partial.fill(identity);
  parallel_chunks(n, grain,
                  [&](std::size_t begin, std::size_t end, std::size_t k) { partial[k] = body(begin, end, identity); });
  T result = identity;
  for (std::size_t k = 0, chunks = chunk_count(n, grain); k < chunks; ++k) result = combine(result, partial[k]);
  return result;
}

}  // namespace hbp::detail
