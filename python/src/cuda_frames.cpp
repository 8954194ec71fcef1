// SPDX-License-Identifier: MIT
#include "cuda_frames.hpp"

#include <pybind11/numpy.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "array_views.hpp"
#include "hbp/box_array.hpp"
#include "hbp/cuda/frame_broadphase.hpp"
#include "hbp/error.hpp"

namespace hbp::python {
namespace {

// A frame's pairs in device memory: (count, 2) uint32, a < b, sorted by
// (a, b) (or in the frame's own order from CudaFrame(sorted=False)). The
// frame that holds them lives as long as this object (and the CuPy array or
// PyTorch tensor made from it, which keeps it referenced).
struct CudaPairs {
  std::shared_ptr<cuda::FrameBroadPhase> frame;
  cuda::DevicePairs pairs;
};

// Version 3 of the CUDA Array Interface. The work is finished when
// find_pairs returns, so no "stream" entry: a consumer need not wait.
py::dict array_interface(const CudaPairs& p) {
  py::dict d;
  d["shape"] = py::make_tuple(p.pairs.count, 2);
  d["typestr"] = "<u4";
  d["data"] = py::make_tuple(reinterpret_cast<std::uintptr_t>(p.pairs.data), false);
  d["strides"] = py::none();
  d["version"] = 3;
  return d;
}

std::int64_t interface_int(py::handle v, const char* what) {
  return integer_arg(py::reinterpret_borrow<py::object>(v),
                     (std::string("boxes: __cuda_array_interface__ ") + what).c_str());
}

// The producer's stream as a cudaStream_t. Version 3 of the interface
// gives an int: 1 the legacy default stream, 2 the per-thread one (the
// runtime's handles cudaStreamLegacy and cudaStreamPerThread have those
// values), else a stream's handle; 0 is refused by the interface itself
// (ambiguous between the two defaults). None or no entry: the data is ready,
// the frame runs on the legacy default stream.
void* stream_of(const py::dict& cai) {
  if (!cai.contains("stream") || cai["stream"].is_none()) return nullptr;
  const py::object value = cai["stream"];
  const std::uint64_t stream = u64_arg(value, "boxes: __cuda_array_interface__ 'stream'");
  if (stream == 0)
    throw ArgumentError("boxes: __cuda_array_interface__ 'stream' 0 is not allowed (1: the legacy default stream, "
                        "2: the per-thread default stream)");
  return reinterpret_cast<void*>(static_cast<std::uintptr_t>(stream));
}

// The rows of an (n, 6) float32 array from its __cuda_array_interface__,
// and the producer's stream. Everything the interface may say is checked
// (then cuda::check_device_rows: the object limit, the pointer's
// alignment): a float64 array would have to be rounded, which can shrink or
// invert a box, so only float32 is taken.
cuda::DeviceRows rows_of(const py::dict& cai, void** stream) {
  for (const char* key : {"shape", "typestr", "data"})
    if (!cai.contains(key)) throw ArgumentError(std::string("boxes: __cuda_array_interface__ has no '") + key + "'");
  const py::object shape = cai["shape"];
  if (!py::isinstance<py::tuple>(shape) || py::len(shape) != 2 ||
      interface_int(shape.cast<py::tuple>()[1], "shape") != 6)
    throw ArgumentError("boxes: a CUDA array of shape (n, 6) is needed, got shape " +
                        py::str(shape).cast<std::string>());
  const std::int64_t n = interface_int(shape.cast<py::tuple>()[0], "shape");
  const std::string typestr = py::str(cai["typestr"]);
  if (typestr != "<f4" && typestr != "|f4")
    throw ArgumentError("boxes: a float32 CUDA array is needed (min x, y, z, max x, y, z per row), got typestr '" +
                        typestr + "'");
  if (cai.contains("mask") && !cai["mask"].is_none()) throw ArgumentError("boxes: masked CUDA arrays are not taken");
  const py::object data = cai["data"];
  if (!py::isinstance<py::tuple>(data) || py::len(data) != 2)
    throw ArgumentError("boxes: __cuda_array_interface__ 'data' must be (pointer, read_only)");
  const std::uint64_t address = u64_arg(data.cast<py::tuple>()[0], "boxes: __cuda_array_interface__ 'data' pointer");
  if (n < 0 || n > cuda::kMaxFrameObjects)
    throw ArgumentError("boxes: " + std::to_string(n) + " rows is out of range (0.." +
                        std::to_string(cuda::kMaxFrameObjects) + ")");
  cuda::DeviceRows rows;
  rows.data = reinterpret_cast<const float*>(static_cast<std::uintptr_t>(address));
  rows.n = static_cast<std::uint32_t>(n);
  if (cai.contains("strides") && !cai["strides"].is_none()) {
    const py::object strides = cai["strides"];
    if (!py::isinstance<py::tuple>(strides) || py::len(strides) != 2)
      throw ArgumentError("boxes: __cuda_array_interface__ 'strides' must be None or two byte strides");
    const std::int64_t row = interface_int(strides.cast<py::tuple>()[0], "strides");
    const std::int64_t column = interface_int(strides.cast<py::tuple>()[1], "strides");
    if (row % 4 != 0 || column % 4 != 0)
      throw ArgumentError("boxes: strides (" + std::to_string(row) + ", " + std::to_string(column) +
                          ") are not whole float32 elements");
    rows.row_stride = row / 4;
    rows.column_stride = column / 4;
  }
  try {
    cuda::check_device_rows(rows);
  } catch (const InvalidInput& e) {
    throw ArgumentError(std::string("boxes: __cuda_array_interface__: ") + e.what());
  }
  *stream = stream_of(cai);
  return rows;
}

// The device rows of `boxes` when it exposes __cuda_array_interface__
// (checked whole: ValueError before any device work), else nothing. An
// object whose interface raises (a PyTorch tensor that requires grad) is a
// ValueError with the producer's message, not an array of another kind.
bool device_rows_of(py::handle boxes, cuda::DeviceRows& rows, void** stream) {
  PyObject* interface = PyObject_GetAttrString(boxes.ptr(), "__cuda_array_interface__");
  if (!interface) {
    if (PyErr_ExceptionMatches(PyExc_AttributeError)) {
      PyErr_Clear();
      return false;
    }
    const py::error_already_set raised;  // takes the error
    throw ArgumentError(std::string("boxes: __cuda_array_interface__ raised ") + raised.what());
  }
  const py::object cai = py::reinterpret_steal<py::object>(interface);
  if (!py::isinstance<py::dict>(cai)) throw ArgumentError("boxes: __cuda_array_interface__ is not a dict");
  rows = rows_of(cai.cast<py::dict>(), stream);
  return true;
}

// The boxes of one frame: rows in device memory, or numpy rows copied into
// lanes. Read with the GIL held; the frame then runs without it.
struct FrameInput {
  bool on_device = false;
  cuda::DeviceRows rows;
  void* stream = nullptr;
  BoxArray lanes;
};

FrameInput frame_input(py::handle boxes, cuda::Launcher launcher) {
  FrameInput in;
  in.on_device = device_rows_of(boxes, in.rows, &in.stream);
  if (in.on_device) {
    if (launcher != cuda::Launcher::Device)
      throw ArgumentError("boxes: a CUDA array needs launcher='device' (this frame runs on the CPU)");
    return in;
  }
  const BoxesView view = boxes_view(boxes, "boxes");
  if (view.boxes.size() > cuda::kMaxFrameObjects)
    throw ArgumentError("boxes: " + std::to_string(view.boxes.size()) + " rows is out of range (0.." +
                        std::to_string(cuda::kMaxFrameObjects) + ")");
  py::gil_scoped_release release;
  in.lanes = box_array_of(view.boxes);
  return in;
}

// The stream an update is told to run on (update(boxes, stream=...)),
// overriding what the array's interface says: an int handle (0 and 1: the
// legacy default stream, 2: the per-thread one), or a stream object of CuPy
// (`ptr`) or PyTorch (`cuda_stream`); nothing for None.
std::optional<void*> stream_arg(const py::object& stream) {
  if (stream.is_none()) return std::nullopt;
  py::object handle = stream;
  for (const char* attribute : {"cuda_stream", "ptr"})
    if (py::hasattr(stream, attribute)) {
      handle = stream.attr(attribute);
      break;
    }
  return reinterpret_cast<void*>(
      static_cast<std::uintptr_t>(u64_arg(handle, "stream (an int handle, or a CuPy or PyTorch stream)")));
}

// Runs `frame` over `in` (no GIL needed): the device pairs, or the host
// pairs left in frame->pairs().
cuda::DevicePairs run_input(cuda::FrameBroadPhase& frame, const FrameInput& in) {
  if (in.on_device) return frame.update_device(in.rows, in.stream);
  frame.update(cuda::lanes_of(in.lanes));
  return {};
}

// The result of a frame run on `in`: a CudaPairs holding `frame` (its
// memory holds the pairs), or numpy pairs.
py::object frame_result(const std::shared_ptr<cuda::FrameBroadPhase>& frame, const FrameInput& in,
                        const cuda::DevicePairs& pairs) {
  if (in.on_device) return py::cast(CudaPairs{frame, pairs});
  return pairs_array(frame->pairs());
}

std::uint64_t max_pairs_arg(long long max_pairs) {
  if (max_pairs < 0) throw ArgumentError("max_pairs: must be >= 0 (0: unlimited), got " + std::to_string(max_pairs));
  return static_cast<std::uint64_t>(max_pairs);
}

// hbp.CudaFrame: the GPU frame kept across frames (its grid, buffers and
// CUDA stream), as GPU engines call it every step. A CudaPairs lies in the
// memory of the frame that made it and holds that frame, so no update may
// run on a frame whose result is still referenced: device results
// alternate between two frames (the usual `p = update(...)` loop drops a
// result before its frame comes round again), and a frame still
// referenced when its turn comes is left to its results and replaced.
// Calls from several Python threads take turns (the GIL is released first).
class PyCudaFrame {
 public:
  explicit PyCudaFrame(const cuda::FrameOptions& o) : options_(o) {
    slots_[0] = std::make_shared<cuda::FrameBroadPhase>(o);  // device: "no CUDA device found" without one
  }
  void reserve(long long n) {
    if (n < 0) throw ArgumentError("reserve: objects must be >= 0, got " + std::to_string(n));
    if (n > 0xffffffffll) throw ArgumentError("reserve: " + std::to_string(n) + " objects is out of range");
    const LockWithoutGil lock(mutex_);
    free_slot()->reserve(static_cast<std::uint32_t>(n));
  }
  py::object update(py::handle boxes, const py::object& stream) {
    const std::optional<void*> given = stream_arg(stream);
    FrameInput in = frame_input(boxes, options_.launcher);
    if (given) {
      if (!in.on_device) throw ArgumentError("stream: only for boxes in device memory (a CUDA array)");
      in.stream = *given;
    }
    std::shared_ptr<cuda::FrameBroadPhase> frame;
    cuda::DevicePairs pairs;
    {
      const LockWithoutGil lock(mutex_);
      frame = free_slot();
      last_ = next_;
      pairs = run_input(*frame, in);
      if (in.on_device) next_ ^= 1;  // this result's frame is not run again while the next one is free
    }
    return frame_result(frame, in, pairs);
  }
  py::dict info() {
    cuda::FrameInfo i;
    {
      const LockWithoutGil lock(mutex_);
      i = slots_[last_]->info();
    }
    const cuda::StageTimes& t = i.times;
    py::dict times;
    const std::pair<const char*, double> stages[] = {
        {"upload", t.upload_ms}, {"bounds", t.bounds_ms}, {"refs", t.refs_ms},   {"sort", t.sort_ms},
        {"count", t.count_ms},   {"fill", t.fill_ms},     {"order", t.order_ms}, {"download", t.download_ms},
        {"frame", t.frame_ms}};
    for (const auto& [name, ms] : stages) times[name] = ms;
    py::dict d;
    d["pairs"] = i.pairs;
    d["references"] = i.references;
    d["cells"] = i.cells;
    d["large"] = i.large;
    d["grid"] = py::make_tuple(i.grid[0], i.grid[1], i.grid[2]);
    d["replanned"] = i.replanned;
    d["allocations"] = i.allocations;
    d["buffer_bytes"] = i.buffer_bytes;
    d["times_ms"] = times;
    return d;
  }

 private:
  // The frame of this turn, made anew when none is there yet or a result
  // (or another call) holds the one there besides its slot. Under mutex_.
  const std::shared_ptr<cuda::FrameBroadPhase>& free_slot() {
    std::shared_ptr<cuda::FrameBroadPhase>& slot = slots_[next_];
    if (!slot || slot.use_count() > 1) slot = std::make_shared<cuda::FrameBroadPhase>(options_);
    return slot;
  }

  cuda::FrameOptions options_;
  std::mutex mutex_;
  std::shared_ptr<cuda::FrameBroadPhase> slots_[2];
  int next_ = 0;  // the slot of the next update
  int last_ = 0;  // the slot of the last update (info()): its frame is the one that ran
};

}  // namespace

void register_cuda_frames(py::module_& m) {
  py::class_<CudaPairs>(m, "CudaPairs",
                        "Pairs of find_pairs(..., engine='cuda') or CudaFrame.update on boxes in device memory: "
                        "(k, 2) uint32, a < b, sorted (unless CudaFrame(sorted=False)), left on the GPU. cupy.asarray(p) and torch.as_tensor(p, device='cuda') take them "
                        "without a copy (__cuda_array_interface__).")
      .def_property_readonly("__cuda_array_interface__", &array_interface,
                             "CUDA Array Interface version 3: shape (k, 2), typestr '<u4', the device pointer")
      .def_property_readonly(
          "shape", [](const CudaPairs& p) { return py::make_tuple(p.pairs.count, 2); }, "(k, 2)")
      .def(
          "__len__", [](const CudaPairs& p) { return p.pairs.count; }, "The number of pairs, k.")
      .def("__repr__",
           [](const CudaPairs& p) { return "CudaPairs(" + std::to_string(p.pairs.count) + " pairs on the GPU)"; });

  py::class_<PyCudaFrame>(m, "CudaFrame",
                          "The whole broad-phase frame on the GPU, kept across frames (grid, device buffers, "
                          "stream): update(boxes) every step. numpy boxes give numpy pairs; boxes with "
                          "__cuda_array_interface__ (CuPy, PyTorch) give a CudaPairs left on the GPU, valid while "
                          "referenced (an update never overwrites a referenced result).")
      .def(py::init([](const std::string& launcher, const py::object& threads, bool sorted, long long max_pairs,
                       const std::string& cell_shape) {
             cuda::FrameOptions o;
             if (launcher == "device") o.launcher = cuda::Launcher::Device;
             else if (launcher == "host") o.launcher = cuda::Launcher::Host;
             else throw ArgumentError("launcher: 'device' or 'host', got '" + launcher + "'");
             o.cell_shape = cuda::parse_cell_shape(cell_shape);  // InvalidInput: a ValueError
             const unsigned t = threads_arg(threads);
             o.threads = t ? t : std::max(1u, std::thread::hardware_concurrency());
             o.sorted = sorted;
             o.max_pairs = max_pairs_arg(max_pairs);
             return std::make_unique<PyCudaFrame>(o);
           }),
           py::kw_only(), py::arg("launcher") = "device", py::arg("threads") = 0, py::arg("sorted") = true,
           py::arg("max_pairs") = 0, py::arg("cell_shape") = "columns",
           "launcher: 'device' (a CUDA GPU; RuntimeError 'no CUDA device found' without one) or 'host' (the same "
           "kernels on CPU threads); threads: the host launcher's, 0 = all cores; sorted: pairs ordered by (a, b), "
           "else the frame's own order; max_pairs: 0 = unlimited, else update() raises CapacityExceeded beyond "
           "it; cell_shape: 'columns' (long on the sweep axis) or 'cubes'.")
      .def("reserve", &PyCudaFrame::reserve, py::arg("n"),
           "Loads the kernels and sizes the next update's buffers for about n objects.")
      .def("update", &PyCudaFrame::update, py::arg("boxes"), py::kw_only(), py::arg("stream") = py::none(),
           "Every overlapping pair of rows of boxes ((n, 6) float32): a (k, 2) uint32 numpy array, or a CudaPairs "
           "for a CUDA array (launcher='device'). ValueError for bad boxes (NaN, min > max: the object is "
           "named), CapacityExceeded past max_pairs. stream: the CUDA stream to run on for a CUDA array (an int "
           "handle, a cupy.cuda.Stream or a torch.cuda.Stream), instead of the one its interface names (PyTorch "
           "names none: the legacy default stream); the work is finished when update returns.")
      .def("info", &PyCudaFrame::info,
           "The last update: pairs, references, cells, large, grid, replanned, allocations, buffer_bytes and "
           "times_ms (upload, bounds, refs, sort, count, fill, order, download, frame: device time on a GPU, "
           "wall time on the host launcher).");
}

py::object find_pairs_cuda(py::handle boxes, long long max_pairs) {
  cuda::FrameOptions options;
  options.launcher = cuda::Launcher::Device;
  options.max_pairs = max_pairs_arg(max_pairs);
  const FrameInput in = frame_input(boxes, options.launcher);  // a bad interface or array: ValueError first
  std::shared_ptr<cuda::FrameBroadPhase> frame;
  cuda::DevicePairs pairs;
  {
    py::gil_scoped_release release;  // a first frame also starts the CUDA context
    frame = std::make_shared<cuda::FrameBroadPhase>(options);  // "no CUDA device found" without one
    pairs = run_input(*frame, in);
  }
  return frame_result(frame, in, pairs);
}

}  // namespace hbp::python
