// SPDX-License-Identifier: MIT
#include "array_views.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>

namespace hbp::python {

// A C-order (n, 6) float32 array is exactly an array of Aabb.
static_assert(std::is_standard_layout_v<Aabb> && std::is_trivially_copyable_v<Aabb>);
static_assert(sizeof(Aabb) == 6 * sizeof(float) && alignof(Aabb) == alignof(float));
static_assert(offsetof(Aabb, min) == 0 && offsetof(Aabb, max) == 3 * sizeof(float));
// A (k, 2) uint32 array is exactly an array of Pair.
static_assert(std::is_standard_layout_v<Pair> && sizeof(Pair) == 2 * sizeof(std::uint32_t));
static_assert(offsetof(Pair, a) == 0 && offsetof(Pair, b) == sizeof(std::uint32_t));
static_assert(std::is_same_v<Handle, std::uint32_t>);

namespace {

std::string shape_string(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) {
    if (d) s += ", ";
    s += std::to_string(a.shape(d));
  }
  if (a.ndim() == 1) s += ",";
  return s + ")";
}

std::string dtype_string(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

py::array as_array(py::handle obj, const char* what) {
  if (obj.is_none()) throw ArgumentError(std::string(what) + ": expected an array, got None");
  py::array a = py::array::ensure(obj);
  if (!a) {
    PyErr_Clear();
    throw ArgumentError(std::string(what) + ": cannot be read as a numpy array");
  }
  return a;
}

bool list_or_tuple(py::handle obj) { return PyList_Check(obj.ptr()) || PyTuple_Check(obj.ptr()); }

// One box or point given as a list or tuple of Python numbers, as a float32
// array: each number rounded to the nearest float32. Rounding is monotone, so
// the converted box overlaps every float32 box the exact one overlaps (it
// can only gain objects within one float32 step of its faces), and a valid
// box stays valid.
py::array float32_numbers(py::handle obj, const char* what) {
  auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a) {
    PyErr_Clear();
    throw ArgumentError(std::string(what) + ": a list or tuple must hold numbers only");
  }
  return a;
}

bool c_contiguous_aligned(const py::array& a, std::size_t alignment) {
  return (a.flags() & py::array::c_style) &&
         reinterpret_cast<std::uintptr_t>(a.data()) % alignment == 0;
}

std::string coord(float v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return py::repr(py::float_(v)).cast<std::string>();
}

}  // namespace

BoxesView boxes_view(py::handle obj, const char* what, bool single) {
  const char* expected = single ? "(6,)" : "(n, 6)";
  // One box may be a list or tuple; many must be a float32 array (a list of
  // rows is refused: converting it silently would cost a copy per call).
  const bool from_list = single && list_or_tuple(obj);
  py::array a;
  if (from_list) {
    a = float32_numbers(obj, what);
  } else {
    a = as_array(obj, what);
  }
  if (!py::isinstance<py::array_t<float>>(a)) {
    throw ArgumentError(std::string(what) + ": dtype must be float32, got " + dtype_string(a) +
                        " (convert explicitly, e.g. " + what +
                        ".astype(np.float32); float64 is not rounded silently)");
  }
  const bool shape_ok = single ? (a.ndim() == 1 && a.shape(0) == 6)
                               : (a.ndim() == 2 && a.shape(1) == 6);
  if (!shape_ok) {
    const bool one_box = !single && a.ndim() == 1 && a.shape(0) == 6;
    throw ArgumentError(std::string(what) + ": shape must be " + expected + " [minx, miny, minz, maxx, maxy, maxz], got " +
                        shape_string(a) + (one_box ? " (one box: a list of one row, [[minx, ..., maxz]])" : ""));
  }
  if (!c_contiguous_aligned(a, alignof(Aabb))) a = a.attr("copy")("C");  // one copy, C order
  BoxesView view;
  const std::size_t n = single ? 1 : static_cast<std::size_t>(a.shape(0));
  view.boxes = std::span<const Aabb>(static_cast<const Aabb*>(a.data()), n);
  view.holder = std::move(a);
  for (std::size_t i = 0; i < n; ++i) {
    const Aabb& b = view.boxes[i];
    if (const char* defect = box_defect(b)) {
      int k = 0;
      while (k < 2 && std::isfinite(b.min[k]) && std::isfinite(b.max[k]) && b.min[k] <= b.max[k]) ++k;
      const char axis = "xyz"[k];
      std::string where = single ? std::string(what) : std::string(what) + " row " + std::to_string(i);
      throw ArgumentError(where + ": " + defect + " on axis " + axis + " (min" + axis + " " + coord(b.min[k]) +
                          ", max" + axis + " " + coord(b.max[k]) + ")");
    }
  }
  return view;
}

BoxesDView boxes_d_view(py::handle obj, const char* what, bool single) {
  const char* expected = single ? "(6,)" : "(n, 6)";
  py::array a;
  if (single && list_or_tuple(obj)) {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
    if (!a) throw ArgumentError(std::string(what) + ": must be 6 numbers [minx, miny, minz, maxx, maxy, maxz]");
  } else {
    a = as_array(obj, what);
  }
  if (!py::isinstance<py::array_t<double>>(a) && !py::isinstance<py::array_t<float>>(a)) {
    throw ArgumentError(std::string(what) + ": dtype must be float64 (or float32, widened exactly) on a "
                        "double_precision BroadPhase, got " + dtype_string(a));
  }
  const bool shape_ok = single ? (a.ndim() == 1 && a.shape(0) == 6) : (a.ndim() == 2 && a.shape(1) == 6);
  if (!shape_ok) {
    throw ArgumentError(std::string(what) + ": shape must be " + expected +
                        " [minx, miny, minz, maxx, maxy, maxz], got " + shape_string(a));
  }
  // float32 -> float64 is exact; one copy only when the input is not
  // already C-order float64.
  if (!py::isinstance<py::array_t<double>>(a) || !c_contiguous_aligned(a, alignof(AabbD)))
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  BoxesDView view;
  const std::size_t n = single ? 1 : static_cast<std::size_t>(a.shape(0));
  view.boxes = std::span<const AabbD>(static_cast<const AabbD*>(a.data()), n);
  view.holder = std::move(a);
  for (std::size_t i = 0; i < n; ++i) {
    if (const char* defect = box_defect(view.boxes[i])) {
      std::string where = single ? std::string(what) : std::string(what) + " row " + std::to_string(i);
      throw ArgumentError(where + ": " + defect);
    }
  }
  return view;
}

HandlesView handles_view(py::handle obj, const char* what) {
  py::array a = as_array(obj, what);
  const char kind = a.dtype().kind();
  if (kind != 'i' && kind != 'u') {
    throw ArgumentError(std::string(what) + ": dtype must be an integer type (uint32 handles), got " +
                        dtype_string(a));
  }
  if (a.ndim() != 1) {
    throw ArgumentError(std::string(what) + ": shape must be (n,), got " + shape_string(a));
  }
  HandlesView view;
  const std::size_t n = static_cast<std::size_t>(a.shape(0));
  if (py::isinstance<py::array_t<std::uint32_t>>(a) && c_contiguous_aligned(a, alignof(Handle))) {
    view.handles = std::span<const Handle>(static_cast<const Handle*>(a.data()), n);
  } else {
    // Other integer types: every value must be a uint32 (checked, not wrapped).
    if (kind == 'u' && a.dtype().itemsize() == 8) {
      py::array_t<std::uint64_t> u = a.attr("astype")("uint64", "C");
      view.converted.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t v = u.data()[i];
        if (v > 0xFFFFFFFFull) {
          throw ArgumentError(std::string(what) + " row " + std::to_string(i) + ": " + std::to_string(v) +
                              " is not a handle (outside uint32)");
        }
        view.converted[i] = static_cast<Handle>(v);
      }
    } else {
      py::array_t<std::int64_t> s = a.attr("astype")("int64", "C");
      view.converted.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        const std::int64_t v = s.data()[i];
        if (v < 0 || v > 0xFFFFFFFFll) {
          throw ArgumentError(std::string(what) + " row " + std::to_string(i) + ": " + std::to_string(v) +
                              " is not a handle (outside uint32)");
        }
        view.converted[i] = static_cast<Handle>(v);
      }
    }
    view.handles = view.converted;
  }
  view.holder = std::move(a);
  return view;
}

void vec3(py::handle obj, const char* what, float out[3]) {
  py::array a = list_or_tuple(obj) ? float32_numbers(obj, what) : as_array(obj, what);
  if (!py::isinstance<py::array_t<float>>(a)) {
    throw ArgumentError(std::string(what) + ": dtype must be float32, got " + dtype_string(a));
  }
  if (a.ndim() != 1 || a.shape(0) != 3) {
    throw ArgumentError(std::string(what) + ": shape must be (3,), got " + shape_string(a));
  }
  py::array_t<float> c = a.attr("astype")("float32", "C");
  for (int k = 0; k < 3; ++k) {
    out[k] = c.data()[k];
    if (!std::isfinite(out[k])) {
      throw ArgumentError(std::string(what) + ": coordinate " + "xyz"[k] + " is " + coord(out[k]) +
                          " (must be finite)");
    }
  }
}

py::array_t<std::uint32_t> pairs_array(const std::vector<Pair>& pairs) {
  py::array_t<std::uint32_t> out({static_cast<py::ssize_t>(pairs.size()), py::ssize_t{2}});
  if (!pairs.empty()) std::memcpy(out.mutable_data(), pairs.data(), pairs.size() * sizeof(Pair));
  return out;
}

BoxArray box_array_of(std::span<const Aabb> boxes) {
  BoxArray soa(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) soa.set(i, boxes[i]);
  return soa;
}

py::array_t<std::uint32_t> handles_array(std::vector<Handle>&& handles) {
  auto* owned = new std::vector<Handle>(std::move(handles));
  py::capsule free_when_done(owned, [](void* p) { delete static_cast<std::vector<Handle>*>(p); });
  return py::array_t<std::uint32_t>({static_cast<py::ssize_t>(owned->size())}, owned->data(), free_when_done);
}

std::int64_t integer_arg(const py::object& v, const char* what) {
  PyObject* index = PyNumber_Index(v.ptr());  // ints and numpy integers, not floats or str
  if (!index) {
    PyErr_Clear();
    throw ArgumentError(std::string(what) + ": expected an integer, got " +
                        py::str(py::type::of(v).attr("__name__")).cast<std::string>());
  }
  int overflow = 0;
  const long long x = PyLong_AsLongLongAndOverflow(index, &overflow);
  Py_DECREF(index);
  if (overflow) throw ArgumentError(std::string(what) + ": " + py::repr(v).cast<std::string>() + " is out of range");
  return x;
}

std::uint64_t u64_arg(const py::object& obj, const char* what) {
  PyObject* index = PyNumber_Index(obj.ptr());
  if (index) {
    const unsigned long long v = PyLong_AsUnsignedLongLong(index);
    Py_DECREF(index);
    if (!PyErr_Occurred()) return v;
  }
  PyErr_Clear();
  throw ArgumentError(std::string(what) + ": must be an integer 0..2**64 - 1, got " + py::repr(obj).cast<std::string>());
}

Handle handle_arg(const py::object& h, const char* what) {
  const std::int64_t v = integer_arg(h, what);
  if (v < 0 || v > 0xFFFFFFFFll) {
    throw ArgumentError(std::string(what) + ": " + std::to_string(v) + " is not a handle (outside uint32)");
  }
  return static_cast<Handle>(v);
}

unsigned threads_arg(const py::object& threads) {
  const std::int64_t v = integer_arg(threads, "threads");
  if (v < 0 || v > static_cast<std::int64_t>(kMaxThreads)) {
    throw ArgumentError("threads: must be 0 (all cores) .. " + std::to_string(kMaxThreads) + ", got " +
                        std::to_string(v));
  }
  return static_cast<unsigned>(v);
}

std::uint8_t layer_arg(const py::object& layer, const char* what) {
  const std::int64_t v = integer_arg(layer, what);
  if (v < 0 || v >= static_cast<std::int64_t>(kLayerCount)) {
    throw ArgumentError(std::string(what) + ": " + std::to_string(v) + " is out of range (0.." +
                        std::to_string(kLayerCount - 1) + ")");
  }
  return static_cast<std::uint8_t>(v);
}

}  // namespace hbp::python
