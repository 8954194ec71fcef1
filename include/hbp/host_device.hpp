// SPDX-License-Identifier: MIT
#pragma once
// HBP_HOST_DEVICE marks a function that host code and CUDA device code both
// call: the GPU kernels and their CPU launcher run the same bodies, and the
// geometry they share (CellRegion::contains, the ownership rule) is written
// once. Under a host compiler it expands to nothing.
#if defined(__CUDACC__)
#define HBP_HOST_DEVICE __host__ __device__
#else
#define HBP_HOST_DEVICE
#endif
