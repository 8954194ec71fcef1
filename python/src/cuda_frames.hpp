// SPDX-License-Identifier: MIT
#pragma once
// find_pairs(boxes, engine="cuda"): the whole frame on the GPU
// (hbp::cuda::FrameBroadPhase). numpy boxes in, numpy pairs out; boxes that
// expose __cuda_array_interface__ (CuPy arrays, PyTorch CUDA tensors) are
// read where they lie and the pairs are left in device memory, returned as a
// CudaPairs object that CuPy and PyTorch take without a copy.
#include <pybind11/pybind11.h>

namespace hbp::python {

namespace py = pybind11;

// Registers CudaPairs in the module.
void register_cuda_frames(py::module_& m);

// The frame for find_pairs: ValueError for a malformed array interface
// (before any device work), RuntimeError "no CUDA device found" without one.
py::object find_pairs_cuda(py::handle boxes, long long max_pairs);

}  // namespace hbp::python
