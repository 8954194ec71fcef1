// SPDX-License-Identifier: MIT
#pragma once
// A frame with no last count (the first) would count its dense cells, then
// run their kernel again to write them (two kernel runs of the densest
// cells). With cells built this frame the list is sized from a sample
// instead: every kFirstFrameSampleStride-th cell counted through the
// streaming door, scaled by entries, given a margin of 1/kFirstFrameMargin,
// capped at the cells' n (n - 1) / 2. An estimate too low leaves middle
// cells that find no room (counted and written in the second pass, the
// fallback of every frame); one too high is cut at the merge.
#include <tbb/enumerable_thread_specific.h>

#include <cstddef>

#include "hbp/kd_partition.hpp"
#include "pipeline/cell_worker.hpp"

namespace hbp::detail {

// The estimated pair count of the frame in `cells` (every worker's engine
// has a streaming door), or 0 when there is none: too few cells to sample,
// or no pairs in the sample. Reads the cells as built (no refresh).
std::size_t sample_frame_pairs(const KdPartition& cells, tbb::enumerable_thread_specific<Worker>& workers);

}  // namespace hbp::detail
