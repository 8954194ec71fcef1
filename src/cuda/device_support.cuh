// SPDX-License-Identifier: MIT
#pragma once
// CUDA error checks and the frame's kept device buffers. A buffer grows
// (a new cudaMalloc, counted) only when a frame needs more than it holds,
// and is given back when it holds more than four times what the frame needs
// beyond 8 MiB (the host launcher's rule), so steady frames allocate nothing
// and memory follows the current frame.
#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "hbp/error.hpp"
#include "support/retained.hpp"

namespace hbp::cuda {

inline void check_cuda(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw Error(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

// Throws hbp::Error "no CUDA device found" unless a device is usable; else
// the caller's current device, the one an object made now runs on.
int require_device();

// The device an object runs on made current for a scope, the caller's
// restored after it: frames, peers and cell engines keep the device they
// were made on whatever the caller makes current between calls (CuPy and
// PyTorch switch devices freely), and leave the caller's choice as it was.
// Never throws (destructors use it too): when the device cannot be made
// current, the scope changes nothing and the next checked call reports.
class DeviceScope {
 public:
  explicit DeviceScope(int device) : device_(device) {
    if (cudaGetDevice(&caller_) != cudaSuccess || (caller_ != device_ && cudaSetDevice(device_) != cudaSuccess)) {
      cudaGetLastError();
      caller_ = device_;
    }
  }
  ~DeviceScope() {
    if (caller_ != device_) cudaSetDevice(caller_);
  }
  DeviceScope(const DeviceScope&) = delete;
  DeviceScope& operator=(const DeviceScope&) = delete;

 private:
  int device_;
  int caller_ = 0;
};

// InvalidInput when `data` lies in the memory of another device than
// `device`: a kernel there would fault and end the context. Managed, host
// and unknown memory are left to the driver.
void check_on_device(const void* data, int device, const char* what);
// InvalidInput when `stream` (a cudaStream_t; null and the special handles
// are the current device's) belongs to another device than `device`: this
// device's kernels cannot be queued on it, and the frame would fail midway.
void check_stream_on_device(void* stream, int device);

class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() { cudaFree(data_); }
  // Makes room for `bytes`; returns whether it allocated. A buffer far
  // larger than asked is given back first (the retained rule of the CPU's
  // buffers, support/retained.hpp). `trim` false for a buffer asked several
  // times per frame for different sizes (the CUB temporary storage): it only
  // grows, or a small request after a large one would give back and
  // reallocate within every frame.
  bool reserve(std::size_t bytes, bool trim = true) {
    if (trim && data_ && retained::oversized(capacity_, bytes, retained::kSlackBytes)) release();
    if (bytes <= capacity_ && data_) return false;
    release();
    // An eighth more than asked: frame-to-frame jitter of the reference and
    // pair counts does not reallocate.
    const std::size_t size = bytes + bytes / 8 + 256;
    check_cuda(cudaMalloc(&data_, size), "cudaMalloc");
    capacity_ = size;
    return true;
  }
  template <class T>
  T* as() const {
    return static_cast<T*>(data_);
  }
  std::size_t capacity() const { return capacity_; }

 private:
  // cudaFree waits for the device's queued work, so a buffer that grows
  // while a queued kernel still reads it (the CUB temporary storage between
  // two calls of a frame) is freed only after that kernel.
  void release() {
    if (data_) cudaFree(data_);
    data_ = nullptr;
    capacity_ = 0;
  }
  void* data_ = nullptr;
  std::size_t capacity_ = 0;
};

}  // namespace hbp::cuda
