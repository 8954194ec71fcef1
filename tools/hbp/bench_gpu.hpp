// SPDX-License-Identifier: MIT
#pragma once
// hbp bench gpu: the whole frame on the GPU (hbp::cuda::FrameBroadPhase)
// against our CPU engine, frame by frame on the same boxes, in the same run.
#include <CLI/CLI.hpp>

namespace hbp::cli {

void add_bench_gpu(CLI::App* bench);

}  // namespace hbp::cli
