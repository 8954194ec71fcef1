// SPDX-License-Identifier: MIT
#pragma once
// Cells through a task in parallel, handed to an ordered sink in cell order
// while later cells are still in the task (the narrow phase consumes cell k
// while the engine works on k+1...), the sink called one cell at a time.
//
// On oneTBB: a pipeline, `tokens` bounding the cells in flight. On the
// engine's task system (support/parallel_for.hpp), which has no pipeline:
// the cells are one parallel loop, and whichever task completes the next
// cell in order publishes it and every completed cell after it (one
// publisher at a time; a cell completed while another task publishes is
// seen by that task's re-check before it lets go).
#include <tbb/parallel_pipeline.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "support/parallel_for.hpp"

namespace hbp::detail {

template <class Task, class Sink>
void stream_in_cell_order(std::uint32_t cells, std::size_t tokens, Task&& task, Sink&& sink) {
  if (task_context().tasks) {
    // Sequentially consistent throughout: a completing task stores done[c]
    // then tries the flag; the publisher clears the flag then re-reads done.
    const std::unique_ptr<std::atomic<bool>[]> done(new std::atomic<bool>[cells]);
    for (std::uint32_t c = 0; c < cells; ++c) done[c] = false;
    std::uint32_t next = 0;  // written by the publisher only
    std::atomic<bool> publishing{false};
    parallel_for_each(cells, [&](std::size_t i) {
      const auto c = static_cast<std::uint32_t>(i);
      task(c);
      done[c] = true;
      while (true) {
        bool idle = false;
        if (!publishing.compare_exchange_strong(idle, true)) return;  // the publisher re-checks
        while (next < cells && done[next]) sink(next++);
        const std::uint32_t waiting = next;  // `next` is the next publisher's once the flag is clear
        publishing = false;
        if (waiting == cells || !done[waiting]) return;
      }
    });
    return;
  }
  std::uint32_t next = 0;
  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, std::uint32_t>(tbb::filter_mode::serial_in_order,
                                            [&](tbb::flow_control& fc) -> std::uint32_t {
                                              if (next >= cells) {
                                                fc.stop();
                                                return 0;
                                              }
                                              return next++;
                                            }) &
          tbb::make_filter<std::uint32_t, std::uint32_t>(tbb::filter_mode::parallel,
                                                         [&](std::uint32_t c) {
                                                           task(c);
                                                           return c;
                                                         }) &
          tbb::make_filter<std::uint32_t, void>(tbb::filter_mode::serial_in_order,
                                                [&](std::uint32_t c) { sink(c); }));
}

}  // namespace hbp::detail
