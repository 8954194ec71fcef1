// SPDX-License-Identifier: MIT
#pragma once
// The GPU accelerator as cell engines of the hybrid system (the paper's own
// split: the CPU's k-d cells streamed to the accelerator):
//   "cuda-host"  the accelerator kernel's body (a lane per box sweeping its
//                cell, the ownership rule fused in) run on the CPU; exact,
//                tested against the brute-force oracle;
//   "cuda"       the same kernel on a CUDA device; make_cell_engine("cuda")
//                throws hbp::Error "no CUDA device found" when there is none.
// register_cell_engines() enters both in the core's engine registry.
// Idempotent; call it before make_cell_engine("cuda-host").
namespace hbp::cuda {

void register_cell_engines();

}  // namespace hbp::cuda
