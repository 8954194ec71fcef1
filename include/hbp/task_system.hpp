// SPDX-License-Identifier: MIT
#pragma once
// An engine's job system, lent to the broad phase (BroadPhaseOptions::
// task_system): the library hands it batches of independent tasks instead
// of running them on its own oneTBB threads.
//
//   struct MyJobs final : hbp::TaskSystem {
//     void run(std::uint32_t n, hbp::TaskFunction fn, void* context) override {
//       pool.for_each(n, [&](std::uint32_t i) { fn(context, i); });  // returns when all are done
//     }
//     unsigned concurrency() const override { return pool.threads(); }
//   };
//   MyJobs jobs;
//   hbp::BroadPhase bp({.task_system = &jobs});
//
// The contract, for an engine implementing run():
// - run(n, fn, context) calls fn(context, i) exactly once for every i in
//   [0, n), on any threads (the calling thread included), in any order, and
//   returns only after every call has returned. It may run them all inline.
// - run() is called from the thread that called into the broad phase
//   (update(), add(), a query, ...), one batch at a time per broad phase,
//   never from inside one of its own tasks: the library runs loops nested
//   in a task inline, so an engine need not support nested batches.
// - fn never throws: an exception of a task is caught by the library, the
//   batch's remaining tasks return at once, and it is rethrown from the
//   broad phase's call after run() returns.
// - The output (pairs, events, hits and their order) does not depend on
//   the task system or on concurrency(): the library splits its work into
//   tasks by fixed sizes and writes results by task index.
#include <cstdint>
#include <memory>

namespace hbp {

// One task of a batch: task is its index in [0, task_count).
using TaskFunction = void (*)(void* context, std::uint32_t task);

class TaskSystem {
 public:
  virtual ~TaskSystem() = default;
  // Runs fn(context, i) for every i in [0, task_count); see the contract
  // above. task_count is at least 1.
  virtual void run(std::uint32_t task_count, TaskFunction fn, void* context) = 0;
  // How many tasks of one batch can run at the same time (the engine's
  // workers, the calling thread included), at least 1. The library sizes
  // how much work it splits off by it (a value of 1 keeps a frame's
  // phases serial), never what it outputs.
  virtual unsigned concurrency() const = 0;
};

// Every task on the calling thread, in index order: for single-threaded
// engines and for tests.
class SerialTaskSystem final : public TaskSystem {
 public:
  void run(std::uint32_t task_count, TaskFunction fn, void* context) override;
  unsigned concurrency() const override { return 1; }
};

// The tasks on a oneTBB arena of `threads` threads (0: all cores; at most
// kMaxThreads, else InvalidInput), the calling thread joining it. The
// broad phase's default (a null task_system) is its own arena like this
// one; one TbbTaskSystem shared by several broad phases shares its threads.
class TbbTaskSystem final : public TaskSystem {
 public:
  explicit TbbTaskSystem(unsigned threads = 0);
  ~TbbTaskSystem() override;
  TbbTaskSystem(const TbbTaskSystem&) = delete;
  TbbTaskSystem& operator=(const TbbTaskSystem&) = delete;
  void run(std::uint32_t task_count, TaskFunction fn, void* context) override;
  unsigned concurrency() const override;

 private:
  struct Arena;
  std::unique_ptr<Arena> arena_;
};

}  // namespace hbp
