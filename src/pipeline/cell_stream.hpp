// SPDX-License-Identifier: MIT
#pragma once
// Cells through a task in parallel, handed to an ordered sink in cell order
// while later cells are still in the task (the narrow phase consumes cell k
// while the engine works on k+1...). `tokens` bounds the cells in flight.
#include <tbb/parallel_pipeline.h>

#include <cstddef>
#include <cstdint>

namespace hbp::detail {

template <class Task, class Sink>
void stream_in_cell_order(std::uint32_t cells, std::size_t tokens, Task&& task, Sink&& sink) {
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
