// SPDX-License-Identifier: MIT
#pragma once
// numpy <-> C++ views for the hybrid_broadphase module. Inputs are checked
// here (shape, dtype, NaN/Inf/inverted boxes, handle range) so every
// ValueError names the argument and the offending row before any C++ state
// changes; a C-contiguous, aligned float32 (n, 6) array is viewed in place
// as hbp::Aabb[n] (no copy), anything else float32 is copied once into C
// order, any other dtype is rejected (float64 -> float32 rounding could
// shrink or invert a box and silently drop pairs). Where one box or one point
// is expected, a Python list or tuple of numbers is accepted too, each
// number rounded to the nearest float32 (monotone: no overlap is lost).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/aabb_d.hpp"
#include "hbp/box_array.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/pair.hpp"

namespace hbp::python {

namespace py = pybind11;

// Thrown for bad arguments; translated to ValueError.
struct ArgumentError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct BoxesView {
  py::array holder;  // the caller's array, or the C-order copy
  std::span<const Aabb> boxes;
};

// `what` names the argument in messages ("boxes", "box"). single: one box of
// shape (6,) instead of (n, 6).
BoxesView boxes_view(py::handle obj, const char* what, bool single = false);

// Double-precision boxes (a BroadPhase(double_precision=True)): (n, 6)
// float64, or float32 widened exactly; one box may be a list or tuple.
struct BoxesDView {
  py::array holder;
  std::span<const AabbD> boxes;
};
BoxesDView boxes_d_view(py::handle obj, const char* what, bool single = false);

struct HandlesView {
  py::array holder;
  std::vector<Handle> converted;  // used when the input was not uint32 C-order
  std::span<const Handle> handles;
};
HandlesView handles_view(py::handle obj, const char* what = "handles");

// One (3,) float32 vector with finite coordinates.
void vec3(py::handle obj, const char* what, float out[3]);

// (k, 2) uint32 copy of canonical pairs.
py::array_t<std::uint32_t> pairs_array(const std::vector<Pair>& pairs);
// Rows of boxes as the structure of arrays the frames take (one copy; no
// Python object touched, so callable without the GIL).
BoxArray box_array_of(std::span<const Aabb> boxes);
// (k,) uint32 array owning the vector's storage (no copy).
py::array_t<std::uint32_t> handles_array(std::vector<Handle>&& handles);

// A Python int (or numpy integer) as a signed / unsigned 64-bit value
// (ValueError naming `what` for a non-integer or one out of range).
std::int64_t integer_arg(const py::object& v, const char* what);
std::uint64_t u64_arg(const py::object& obj, const char* what);
// A Python int as a handle (ValueError when outside uint32).
Handle handle_arg(const py::object& h, const char* what = "handle");
// A Python int as a thread count 0 (all cores) .. kMaxThreads.
unsigned threads_arg(const py::object& threads);

// Exclusive access to an object that several Python threads share: the GIL
// released first, then the mutex taken (a thread holding the mutex may need
// the GIL to finish: the other order could deadlock), both given back in
// reverse order.
class LockWithoutGil {
 public:
  explicit LockWithoutGil(std::mutex& m) : lock_(m) {}

 private:
  py::gil_scoped_release release_;
  std::lock_guard<std::mutex> lock_;
};
// A Python int as a layer 0..31.
std::uint8_t layer_arg(const py::object& layer, const char* what = "layer");

}  // namespace hbp::python
