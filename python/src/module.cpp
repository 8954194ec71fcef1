// SPDX-License-Identifier: MIT
// The Python module hybrid_broadphase: find_pairs on one frame and
// BroadPhase, the handle-based broad phase, on numpy arrays. docs/python.md.
//
// Threads: every call releases the GIL while C++ works and takes the
// object's mutex after releasing it (never the other way round, so a pair
// filter that needs the GIL on a worker thread cannot deadlock against
// another Python thread waiting for the mutex).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "array_views.hpp"
#include "hbp/box_array.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#ifdef HBP_HAVE_CUDA
#include "cuda_frames.hpp"
#include "hbp/cuda/cuda_engines.hpp"
#endif
#include "hbp/hybrid_broadphase.hpp"

#ifndef HBP_VERSION
#define HBP_VERSION "unknown"
#endif

namespace hbp::python {
namespace {

BroadPhaseOptions make_options(const std::string& engine, const py::object& threads, long long cell_limit,
                               long long max_pairs, bool double_precision = false) {
  if (cell_limit < 0 || cell_limit == 1 || cell_limit > 0xFFFFFFFFll) {
    throw ArgumentError("cell_limit: must be 0 (engine default) or >= 2, got " + std::to_string(cell_limit));
  }
  if (max_pairs < 0) throw ArgumentError("max_pairs: must be >= 0 (0: unlimited), got " + std::to_string(max_pairs));
  BroadPhaseOptions o;
  o.engine = engine;
  o.threads = threads_arg(threads);
  o.cell_limit = static_cast<std::uint32_t>(cell_limit);
  o.max_pairs = static_cast<std::uint64_t>(max_pairs);
  o.sorted = true;
  o.double_precision = double_precision;
  return o;
}

py::object find_pairs(py::handle boxes_obj, const std::string& engine, const py::object& threads, long long cell_limit,
                      long long max_pairs) {
#ifdef HBP_HAVE_CUDA
  if (engine == "cuda") {
    // The whole frame on the GPU: its grid is its own, and CPU threads do
    // not apply (still checked, so a bad value is an error everywhere).
    threads_arg(threads);
    if (cell_limit != 0)
      throw ArgumentError("cell_limit: engine 'cuda' plans its own cells, leave it 0 (got " +
                          std::to_string(cell_limit) + ")");
    return find_pairs_cuda(boxes_obj, max_pairs);
  }
#endif
  const BoxesView view = boxes_view(boxes_obj, "boxes");
  const BroadPhaseOptions options = make_options(engine, threads, cell_limit, max_pairs);
  std::vector<Pair> pairs;
  {
    py::gil_scoped_release release;
    // The engine's input is structure-of-arrays: one copy is unavoidable here.
    const BoxArray soa = box_array_of(view.boxes);
    HybridBroadPhase bp(options);  // also validates the engine name and options
    pairs = bp.update(soa);
  }
  return pairs_array(pairs);
}

// Exclusive access to one BroadPhase (LockWithoutGil).
// A pair filter runs inside update(), which holds the mutex: a filter calling
// back into its BroadPhase would wait for itself. Refused instead.
thread_local bool t_in_pair_filter = false;

class Exclusive {
 public:
  explicit Exclusive(std::mutex& m) : lock_(m) {}

 private:
  static bool refuse_reentry() {
    if (t_in_pair_filter) {
      throw std::runtime_error("a pair filter cannot call its BroadPhase (update() is running)");
    }
    return true;
  }
  bool not_reentrant_ = refuse_reentry();  // first: before anything is released or locked
  LockWithoutGil lock_;
};

// Result of BroadPhase.update(): copies, so they stay valid after the next update.
struct UpdateResult {
  py::array_t<std::uint32_t> pairs, created, removed;
};

// Thrown through BroadPhase::update() when the Python filter raised: the C++
// broad phase then leaves the frame unapplied (see update() below).
struct FilterRaised {};

// A Python callable as a BroadPhase::PairFilter. Called from worker threads:
// it takes the GIL per call. The first exception it raises is kept and
// FilterRaised thrown (also by the calls still running on other threads), so
// update() stops, applies nothing, and re-raises that exception.
struct PythonPairFilter {
  std::shared_ptr<py::function> fn;  // destroyed under the GIL (deleter)
  std::shared_ptr<std::mutex> error_mutex;
  std::shared_ptr<std::exception_ptr> error;

  bool operator()(Handle a, Handle b) const {
    {
      py::gil_scoped_acquire gil;
      {
        std::lock_guard lock(*error_mutex);
        if (*error) throw FilterRaised{};
      }
      try {
        t_in_pair_filter = true;
        const bool keep = (*fn)(a, b).cast<bool>();
        t_in_pair_filter = false;
        return keep;
      } catch (...) {
        t_in_pair_filter = false;
        std::lock_guard lock(*error_mutex);
        if (!*error) *error = std::current_exception();
      }
    }
    throw FilterRaised{};  // the GIL released first
  }
};

// A Python int as a signed 32-bit value (ValueError outside the range or for
// a non-integer).
std::int32_t i32_arg(const py::object& obj, const char* what) {
  PyObject* index = PyNumber_Index(obj.ptr());
  if (index) {
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(index, &overflow);
    Py_DECREF(index);
    if (!PyErr_Occurred() && !overflow && v >= INT32_MIN && v <= INT32_MAX) return static_cast<std::int32_t>(v);
  }
  PyErr_Clear();
  throw ArgumentError(std::string(what) + ": must be an integer -2**31..2**31 - 1, got " + py::repr(obj).cast<std::string>());
}
Filter filter_args(const py::object& category, const py::object& mask, const py::object& group) {
  return {u64_arg(category, "category"), u64_arg(mask, "mask"), i32_arg(group, "group")};
}
QueryFilter query_filter_args(const py::object& layers_mask, const py::object& category_mask) {
  const std::uint64_t layers = u64_arg(layers_mask, "layers_mask");
  if (layers > 0xFFFFFFFFull) throw ArgumentError("layers_mask: must be 0..2**32 - 1 (one bit per layer)");
  return {static_cast<std::uint32_t>(layers), u64_arg(category_mask, "category_mask")};
}

class PyBroadPhase {
 public:
  PyBroadPhase(const std::string& engine, const py::object& threads, long long cell_limit, long long max_pairs,
               bool double_precision)
      : bp_(make_options(engine, threads, cell_limit, max_pairs, double_precision)) {}

  py::array_t<std::uint32_t> add(py::handle boxes_obj, bool is_static, const py::object& layer,
                                 const py::object& category, const py::object& mask, const py::object& group,
                                 const py::object& user_data, double margin) {
    const AddOptions options{.is_static = is_static,
                             .layer = layer_arg(layer),
                             .filter = filter_args(category, mask, group),
                             .user_data = u64_arg(user_data, "user_data"),
                             .margin = margin_arg(margin)};
    if (double_precision()) return add_view(boxes_d_view(boxes_obj, "boxes"), options);
    return add_view(boxes_view(boxes_obj, "boxes"), options);
  }

  // add and move of a float (BoxesView) or double (BoxesDView) batch.
  template <class View>
  py::array_t<std::uint32_t> add_view(const View& view, const AddOptions& options) {
    std::vector<Handle> handles;
    {
      Exclusive lock(mutex_);
      if (size_without_lock() + view.boxes.size() > kMaxObjects) {
        throw ArgumentError("boxes: adding " + std::to_string(view.boxes.size()) + " objects to " +
                            std::to_string(bp_.size()) + " exceeds the limit of " + std::to_string(kMaxObjects) +
                            " live objects");
      }
      handles = bp_.add(view.boxes, options);
    }
    return handles_array(std::move(handles));
  }
  template <class View>
  void move_view(const HandlesView& h, const View& b) {
    if (h.handles.size() != b.boxes.size()) {
      throw ArgumentError("move: " + std::to_string(h.handles.size()) + " handles but " +
                          std::to_string(b.boxes.size()) + " boxes (must be equal)");
    }
    Exclusive lock(mutex_);
    check_live(h.handles);  // duplicates in the batch: the C++ side names both rows
    bp_.move(h.handles, b.boxes);
  }

  void reserve(long long objects) {
    if (objects < 0 || static_cast<unsigned long long>(objects) > kMaxObjects)
      throw ArgumentError("reserve: objects must be 0.." + std::to_string(kMaxObjects) + ", got " +
                          std::to_string(objects));
    Exclusive lock(mutex_);
    bp_.reserve(static_cast<std::size_t>(objects));
  }

  void move(py::handle handles_obj, py::handle boxes_obj) {
    const HandlesView h = handles_view(handles_obj);
    if (double_precision()) return move_view(h, boxes_d_view(boxes_obj, "boxes"));
    move_view(h, boxes_view(boxes_obj, "boxes"));
  }

  void remove(py::handle handles_obj) {
    const HandlesView h = handles_view(handles_obj);
    Exclusive lock(mutex_);
    check_live(h.handles);  // duplicates in the batch: the C++ side names both rows
    bp_.remove(h.handles);
  }

  void set_layer(py::handle handles_obj, const py::object& layer) {
    const HandlesView h = handles_view(handles_obj);
    const std::uint8_t l = layer_arg(layer);
    Exclusive lock(mutex_);
    check_live(h.handles);
    bp_.set_layer(h.handles, l);
  }

  void set_static(py::handle handles_obj, bool is_static) {
    const HandlesView h = handles_view(handles_obj);
    Exclusive lock(mutex_);
    check_live(h.handles);  // duplicates in the batch: the C++ side names both rows
    bp_.set_static(h.handles, is_static);
  }

  py::bytes snapshot() {
    std::vector<std::byte> data;
    {
      Exclusive lock(mutex_);
      data = bp_.snapshot();
    }
    return py::bytes(reinterpret_cast<const char*>(data.data()), data.size());
  }

  // Any C-contiguous bytes-like object (bytes, bytearray, memoryview, a
  // uint8 numpy array). The buffer is released under the GIL, after the
  // lock is given back.
  void restore(py::handle data) {
    with_bytes(data, "restore", [&](std::span<const std::byte> bytes) {
      Exclusive lock(mutex_);
      bp_.restore(bytes);
    });
  }

  // f(the bytes of `data`) for any C-contiguous bytes-like object (bytes,
  // bytearray, memoryview, a uint8 numpy array); the buffer is released
  // under the GIL after f.
  template <class F>
  static void with_bytes(py::handle data, const char* call, F&& f) {
    struct Buffer {
      Py_buffer view{};
      bool held = false;
      ~Buffer() {
        if (held) PyBuffer_Release(&view);
      }
    } buffer;
    if (PyObject_GetBuffer(data.ptr(), &buffer.view, PyBUF_SIMPLE) != 0) {
      PyErr_Clear();
      throw ArgumentError(std::string(call) +
                          ": data must be a contiguous bytes-like object (bytes, bytearray, memoryview), got " +
                          py::str(py::type::of(data).attr("__name__")).cast<std::string>());
    }
    buffer.held = true;
    f(std::span<const std::byte>(static_cast<const std::byte*>(buffer.view.buf),
                                 static_cast<std::size_t>(buffer.view.len)));
  }

  // Takes over a broad phase made elsewhere (from_snapshot).
  void adopt(BroadPhase&& other) {
    Exclusive lock(mutex_);
    bp_ = std::move(other);
  }

  void set_collides(const py::object& a, const py::object& b, bool collides) {
    const std::uint8_t la = layer_arg(a, "layer_a"), lb = layer_arg(b, "layer_b");
    Exclusive lock(mutex_);
    bp_.set_collides(la, lb, collides);
  }

  bool collides(const py::object& a, const py::object& b) {
    const std::uint8_t la = layer_arg(a, "layer_a"), lb = layer_arg(b, "layer_b");
    Exclusive lock(mutex_);
    return bp_.collides(la, lb);
  }

  void set_pair_filter(const py::object& fn) {
    BroadPhase::PairFilter filter;
    if (!fn.is_none()) {
      if (!PyCallable_Check(fn.ptr())) {
        throw ArgumentError("set_pair_filter: expected a callable f(a, b) -> bool or None, got " +
                            py::str(py::type::of(fn).attr("__name__")).cast<std::string>());
      }
      auto* held = new py::function(py::reinterpret_borrow<py::function>(fn));
      filter = PythonPairFilter{
          std::shared_ptr<py::function>(held,
                                        [](py::function* f) {
                                          py::gil_scoped_acquire gil;
                                          delete f;
                                        }),
          filter_error_mutex_, filter_error_};
    }
    Exclusive lock(mutex_);
    bp_.set_pair_filter(std::move(filter));
  }

  // A pair filter that raises: the exception propagates and the frame is not
  // applied (BroadPhase::update's contract for a throwing filter), so the
  // next update() reports every change since the last completed one.
  UpdateResult update() {
    std::vector<Pair> pairs, created, removed;
    std::exception_ptr filter_error;
    {
      Exclusive lock(mutex_);
      try {
        const BroadPhaseUpdate& u = bp_.update();
        pairs = u.pairs;
        created = u.created;
        removed = u.removed;
      } catch (const FilterRaised&) {
      }
      std::lock_guard error_lock(*filter_error_mutex_);
      filter_error = std::exchange(*filter_error_, nullptr);
    }
    if (filter_error) std::rethrow_exception(filter_error);
    return {pairs_array(pairs), pairs_array(created), pairs_array(removed)};
  }

  py::array_t<std::uint32_t> query_box(py::handle box_obj, const py::object& layers_mask,
                                       const py::object& category_mask) {
    const QueryFilter qf = query_filter_args(layers_mask, category_mask);
    if (double_precision()) return query_box_view(boxes_d_view(box_obj, "box", /*single=*/true), qf);
    return query_box_view(boxes_view(box_obj, "box", /*single=*/true), qf);
  }

  // Many box queries in one call: row i's hits are handles[offsets[i]:offsets[i + 1]].
  py::tuple query_boxes(py::handle boxes_obj) {
    if (double_precision()) return query_boxes_view(boxes_d_view(boxes_obj, "boxes"));
    return query_boxes_view(boxes_view(boxes_obj, "boxes"));
  }

  // query_box and query_boxes of a float (BoxesView) or double (BoxesDView) batch.
  template <class View>
  py::array_t<std::uint32_t> query_box_view(const View& view, const QueryFilter& filter) {
    std::vector<Handle> hits;
    {
      Exclusive lock(mutex_);
      hits = bp_.query_box(view.boxes[0], filter);
    }
    return handles_array(std::move(hits));
  }
  template <class View>
  py::tuple query_boxes_view(const View& view) {
    py::array_t<std::int64_t> offsets(static_cast<py::ssize_t>(view.boxes.size() + 1));
    std::int64_t* off = offsets.mutable_data();
    std::vector<Handle> all, hits;
    {
      Exclusive lock(mutex_);
      off[0] = 0;
      for (std::size_t i = 0; i < view.boxes.size(); ++i) {
        bp_.query_box(view.boxes[i], hits);
        all.insert(all.end(), hits.begin(), hits.end());
        off[i + 1] = static_cast<std::int64_t>(all.size());
      }
    }
    return py::make_tuple(std::move(offsets), handles_array(std::move(all)));
  }

  // A ray's origin, direction and max_t, checked (max_t beyond float's
  // range: the whole ray).
  struct RayArgs {
    BroadPhase::Vec3f origin, direction;
    float max_t;
  };
  static RayArgs ray_args(py::handle origin_obj, py::handle direction_obj, double max_t) {
    RayArgs r;
    vec3(origin_obj, "origin", r.origin.data());
    vec3(direction_obj, "direction", r.direction.data());
    if (!(max_t >= 0)) {  // NaN too; infinity: the whole ray
      throw ArgumentError("max_t: must be >= 0 (infinity allowed), got " + py::repr(py::float_(max_t)).cast<std::string>());
    }
    r.max_t = max_t > std::numeric_limits<float>::max() ? std::numeric_limits<float>::infinity()
                                                        : static_cast<float>(max_t);
    return r;
  }

  py::array_t<std::uint32_t> query_ray(py::handle origin_obj, py::handle direction_obj, double max_t,
                                       const py::object& layers_mask, const py::object& category_mask) {
    const QueryFilter qf = query_filter_args(layers_mask, category_mask);
    const RayArgs r = ray_args(origin_obj, direction_obj, max_t);
    std::vector<Handle> hits;
    {
      Exclusive lock(mutex_);
      hits = bp_.query_ray(r.origin, r.direction, r.max_t, qf);
    }
    return handles_array(std::move(hits));
  }

  // query_ray's first hit as (handle, t), or None.
  py::object raycast_closest(py::handle origin_obj, py::handle direction_obj, double max_t,
                             const py::object& layers_mask, const py::object& category_mask) {
    const QueryFilter qf = query_filter_args(layers_mask, category_mask);
    const RayArgs r = ray_args(origin_obj, direction_obj, max_t);
    std::optional<RayHit> hit;
    {
      Exclusive lock(mutex_);
      hit = bp_.raycast_closest(r.origin, r.direction, r.max_t, qf);
    }
    if (!hit) return py::none();
    return py::make_tuple(hit->handle, static_cast<double>(hit->t));
  }

  py::array_t<std::uint32_t> box_cast(py::handle box_obj, py::handle displacement_obj, const py::object& layers_mask,
                                      const py::object& category_mask) {
    const BoxesView view = boxes_view(box_obj, "box", /*single=*/true);
    const QueryFilter qf = query_filter_args(layers_mask, category_mask);
    float d[3];
    vec3(displacement_obj, "displacement", d);
    std::vector<Handle> hits;
    {
      Exclusive lock(mutex_);
      hits = bp_.query_box_cast(view.boxes[0], {d[0], d[1], d[2]}, qf);
    }
    return handles_array(std::move(hits));
  }

  static float margin_arg(double margin) {
    if (!(margin >= 0) || !(margin <= std::numeric_limits<float>::max()))
      throw ArgumentError("margin: must be finite and >= 0, got " + py::repr(py::float_(margin)).cast<std::string>());
    return static_cast<float>(margin);
  }
  void set_margin(py::handle handles_obj, double margin) {
    const HandlesView h = handles_view(handles_obj);
    const float m = margin_arg(margin);
    Exclusive lock(mutex_);
    check_live(h.handles);
    bp_.set_margin(h.handles, m);
  }
  double margin(const py::object& h) {
    const Handle handle = handle_arg(h);
    Exclusive lock(mutex_);
    return bp_.margin(handle);
  }
  void move_swept(py::handle handles_obj, py::handle boxes_obj) {
    const HandlesView h = handles_view(handles_obj);
    const BoxesView b = boxes_view(boxes_obj, "boxes");
    if (h.handles.size() != b.boxes.size()) {
      throw ArgumentError("move_swept: " + std::to_string(h.handles.size()) + " handles but " +
                          std::to_string(b.boxes.size()) + " boxes (must be equal)");
    }
    Exclusive lock(mutex_);
    check_live(h.handles);
    bp_.move_swept(h.handles, b.boxes);
  }

  void set_filter(py::handle handles_obj, const py::object& category, const py::object& mask,
                  const py::object& group) {
    const HandlesView h = handles_view(handles_obj);
    const Filter f = filter_args(category, mask, group);
    Exclusive lock(mutex_);
    check_live(h.handles);
    bp_.set_filter(h.handles, f);
  }
  py::tuple filter(const py::object& h) {
    const Handle handle = handle_arg(h);
    Filter f;
    {
      Exclusive lock(mutex_);
      f = bp_.filter(handle);
    }
    return py::make_tuple(f.category, f.mask, f.group);
  }
  void set_user_data(py::handle handles_obj, py::handle values_obj) {
    const HandlesView h = handles_view(handles_obj);
    std::vector<std::uint64_t> values;
    for (py::handle v : py::iter(values_obj)) values.push_back(u64_arg(py::reinterpret_borrow<py::object>(v), "values"));
    if (values.size() != h.handles.size()) {
      throw ArgumentError("set_user_data: " + std::to_string(h.handles.size()) + " handles but " +
                          std::to_string(values.size()) + " values (must be equal)");
    }
    Exclusive lock(mutex_);
    check_live(h.handles);
    bp_.set_user_data(h.handles, values);
  }
  std::uint64_t user_data(const py::object& h) {
    const Handle handle = handle_arg(h);
    Exclusive lock(mutex_);
    return bp_.user_data(handle);
  }
  // (k, 2) uint64 user data of (k, 2) handle pairs (0 for objects gone).
  py::array_t<std::uint64_t> pair_user_data(py::handle pairs_obj) {
    py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast> a = py::array::ensure(pairs_obj);
    if (!a || (!(a.ndim() == 2 && a.shape(1) == 2) && !(a.ndim() == 1 && a.shape(0) == 0)))
      throw ArgumentError("pairs: must be a (k, 2) array of handles");
    const std::size_t k = a.ndim() == 2 ? static_cast<std::size_t>(a.shape(0)) : 0;
    std::vector<Pair> pairs(k);
    for (std::size_t i = 0; i < k; ++i) pairs[i] = Pair{a.data()[2 * i], a.data()[2 * i + 1]};
    py::array_t<std::uint64_t> out({static_cast<py::ssize_t>(k), py::ssize_t{2}});
    {
      Exclusive lock(mutex_);
      bp_.pair_user_data(pairs, std::span<std::array<std::uint64_t, 2>>(
                                    reinterpret_cast<std::array<std::uint64_t, 2>*>(out.mutable_data()), k));
    }
    return out;
  }

  std::size_t size() {
    Exclusive lock(mutex_);
    return bp_.size();
  }
  bool contains(const py::object& h) {
    PyObject* index = PyNumber_Index(h.ptr());
    if (!index) {
      PyErr_Clear();
      return false;
    }
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(index, &overflow);
    Py_DECREF(index);
    if (overflow || v < 0 || v > 0xFFFFFFFFll) return false;
    Exclusive lock(mutex_);
    return bp_.contains(static_cast<Handle>(v));
  }
  py::array box(const py::object& h) {
    if (double_precision()) return box_array<AabbD>(h);
    return box_array<Aabb>(h);
  }
  // A live object's box as 6 numbers of the broad phase's precision
  // (Aabb: float, AabbD: double).
  template <class Box>
  py::array box_array(const py::object& h) {
    const Handle handle = handle_arg(h);
    Box b;
    {
      Exclusive lock(mutex_);
      check_live(std::span<const Handle>(&handle, 1), "handle");
      if constexpr (std::is_same_v<Box, AabbD>)
        b = bp_.box_d(handle);
      else
        b = bp_.box(handle);
    }
    py::array_t<std::remove_cvref_t<decltype(b.min[0])>> out(6);
    std::memcpy(out.mutable_data(), &b, sizeof b);
    return out;
  }
  bool is_static(const py::object& h) {
    const Handle handle = handle_arg(h);
    Exclusive lock(mutex_);
    check_live(std::span<const Handle>(&handle, 1), "handle");
    return bp_.is_static(handle);
  }
  int layer(const py::object& h) {
    const Handle handle = handle_arg(h);
    Exclusive lock(mutex_);
    check_live(std::span<const Handle>(&handle, 1), "handle");
    return bp_.layer(handle);
  }
  py::dict stats() {
    BroadPhaseUpdateStats s;
    {
      Exclusive lock(mutex_);
      s = bp_.stats();
    }
    py::dict d;
    d["moving"] = s.moving;
    d["statics"] = s.statics;
    d["moved"] = s.moved;
    d["static_changes"] = s.static_changes;
    d["wall_ms"] = s.wall_ms;
    return d;
  }
  const BroadPhaseOptions& options() const { return bp_.options(); }

  // ---- large worlds ----------------------------------------------------------

  bool double_precision() const { return bp_.options().double_precision; }

  void shift_origin(py::handle offset_obj) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(offset_obj);
    if (!a || a.ndim() != 1 || a.shape(0) != 3)
      throw ArgumentError("offset: must be 3 numbers (x, y, z)");
    const std::array<double, 3> offset{a.data()[0], a.data()[1], a.data()[2]};
    Exclusive lock(mutex_);
    bp_.shift_origin_d(offset);
  }

 private:
  std::size_t size_without_lock() const { return bp_.size(); }

  // Names the first unknown or stale handle by row (mutex held).
  void check_live(std::span<const Handle> handles, const char* what = "handles") const {
    for (std::size_t i = 0; i < handles.size(); ++i) {
      if (!bp_.contains(handles[i])) {
        const std::string where = handles.size() == 1 && std::string(what) == "handle"
                                      ? std::string(what)
                                      : std::string(what) + " row " + std::to_string(i);
        throw ArgumentError(where + ": handle " + std::to_string(handles[i]) +
                            " is unknown or stale (removed)");
      }
    }
  }

  BroadPhase bp_;
  std::mutex mutex_;
  std::shared_ptr<std::mutex> filter_error_mutex_ = std::make_shared<std::mutex>();
  std::shared_ptr<std::exception_ptr> filter_error_ = std::make_shared<std::exception_ptr>();
};

// Private: the address the module would hand to C++ for `boxes` (the
// zero-copy test compares it with boxes.ctypes.data).
std::uintptr_t boxes_address(py::handle boxes) {
  const BoxesView view = boxes_view(boxes, "boxes");
  return reinterpret_cast<std::uintptr_t>(view.boxes.data());
}

}  // namespace
}  // namespace hbp::python

PYBIND11_MODULE(hybrid_broadphase, m) {
  using namespace hbp::python;
  using hbp::python::PyBroadPhase;
  hbp::hw::register_cell_engines();  // engine='ae', 'mo', 'ae-sim', 'mo-sim'
#ifdef HBP_HAVE_CUDA
  hbp::cuda::register_cell_engines();  // engine='cuda' (a CUDA device), 'cuda-host' (its kernel on the CPU)
  register_cuda_frames(m);
#endif
  m.doc() =
      "Hybrid broad-phase collision detection on numpy arrays: find_pairs(boxes) for one frame, "
      "BroadPhase for persistent handles, static objects, pair events, layers and queries. "
      "Boxes are (n, 6) float32 [minx, miny, minz, maxx, maxy, maxz], closed (touching faces overlap).";
  m.attr("__version__") = HBP_VERSION;
  m.attr("LAYER_COUNT") = hbp::kLayerCount;
  m.attr("MAX_OBJECTS") = hbp::kMaxObjects;
  m.attr("MAX_THREADS") = hbp::kMaxThreads;

  static py::exception<hbp::CapacityExceeded> capacity_exceeded(m, "CapacityExceeded", PyExc_RuntimeError);
  capacity_exceeded.attr("__doc__") =
      "More pairs than max_pairs (find_pairs, BroadPhase.update); a RuntimeError. The BroadPhase keeps its "
      "previous result.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ArgumentError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const hbp::InvalidInput& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const hbp::CapacityExceeded& e) {
      capacity_exceeded(e.what());
    } catch (const hbp::Error& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  m.def("find_pairs", &find_pairs, py::arg("boxes"), py::kw_only(), py::arg("engine") = "sw",
        py::arg("threads") = 0, py::arg("cell_limit") = 0, py::arg("max_pairs") = 0,
        "Every overlapping pair of rows of boxes ((n, 6) float32), as a (k, 2) uint32 array, "
        "a < b, sorted. engine: a cell engine name ('sw' default; 'cuda': the whole frame on the GPU, and "
        "boxes with __cuda_array_interface__ (CuPy, PyTorch) give a CudaPairs left on the GPU); "
        "threads: 0 = all cores; max_pairs: 0 = unlimited, else CapacityExceeded beyond.");
  m.def("_boxes_address", &boxes_address, py::arg("boxes"),
        "Private (tests): the address the module reads boxes from (equals boxes.ctypes.data when no copy is made).");

  py::class_<UpdateResult>(m, "UpdateResult", "Pairs of one BroadPhase.update(): (k, 2) uint32 handle pairs, a < b, sorted.")
      .def_readonly("pairs", &UpdateResult::pairs, "every reported pair now")
      .def_readonly("created", &UpdateResult::created, "in pairs now, not at the previous update")
      .def_readonly("removed", &UpdateResult::removed, "at the previous update, not now")
      .def("__iter__", [](const UpdateResult& r) {  // pairs, created, removed = bp.update()
        return py::iter(py::make_tuple(r.pairs, r.created, r.removed));
      }, "Iterates pairs, created, removed: `pairs, created, removed = bp.update()`.")
      .def("__repr__", [](const UpdateResult& r) {
        return "UpdateResult(pairs=" + std::to_string(r.pairs.shape(0)) + ", created=" +
               std::to_string(r.created.shape(0)) + ", removed=" + std::to_string(r.removed.shape(0)) + ")";
      }, "The three counts, e.g. UpdateResult(pairs=2, created=1, removed=0).");

  py::class_<PyBroadPhase> broad_phase(m, "BroadPhase",
                           "Persistent handles, static and moving objects, pair events, layer filtering and "
                           "queries. Edits take effect at the next update(); a call that raises changes nothing.");
  broad_phase
      .def(py::init<const std::string&, const py::object&, long long, long long, bool>(), py::kw_only(),
           py::arg("engine") = "sw", py::arg("threads") = 0, py::arg("cell_limit") = 0, py::arg("max_pairs") = 0,
           py::arg("double_precision") = false,
           "An empty broad phase. engine: a cell engine name ('sw' default); threads: 0 = all cores; "
           "cell_limit: 0 = the engine's default, else >= 2; max_pairs: 0 = unlimited, else update() raises "
           "CapacityExceeded beyond it; double_precision: boxes are float64 (add, move, query_box(es), box), "
           "pairs exact on the doubles. ValueError for an unknown engine or a bad option.")
      .def("shift_origin", &PyBroadPhase::shift_origin, py::arg("offset"),
           "Re-bases every object by subtracting offset (3 numbers): each coordinate becomes x - offset rounded "
           "in the box's precision (float32, the offset rounded to float32 first; float64 in double_precision "
           "mode). Later boxes are in the new frame; the next update() reports events only for pairs whose "
           "overlap the rounding changed. ValueError for a non-finite offset or a coordinate leaving the finite "
           "range (nothing applied).")
      .def_property_readonly("double_precision", [](const PyBroadPhase& b) { return b.double_precision(); },
                             "Whether boxes are float64 (BroadPhase(double_precision=True)).")
      .def("add", &PyBroadPhase::add, py::arg("boxes"), py::kw_only(), py::arg("static") = false,
           py::arg("layer") = 0, py::arg("category") = 1, py::arg("mask") = py::int_(~std::uint64_t{0}),
           py::arg("group") = 0, py::arg("user_data") = 0, py::arg("margin") = 0.0,
           "Adds (n, 6) float32 boxes, moving or static (static objects are never paired with each other), on "
           "layer, with the filter (category, mask, group: Box2D's b2Filter rule, see set_filter) and user_data "
           "(a 64-bit int each) and margin (>= 0: grown onto every box given, see set_margin); returns their "
           "(n,) uint32 handles in order. ValueError naming the first bad row. On a double_precision "
           "BroadPhase the boxes are (n, 6) float64 (float32 is widened exactly).")
      .def("set_margin", &PyBroadPhase::set_margin, py::arg("handles"), py::arg("margin"),
           "Grows every box given to these objects from now on (add, move, move_swept) by margin on every "
           "side: pairs and queries see the grown boxes (a speculative contact distance). margin >= 0, finite.")
      .def("margin", &PyBroadPhase::margin, py::arg("handle"), "The object's margin.")
      .def("move_swept", &PyBroadPhase::move_swept, py::arg("handles"), py::arg("boxes"),
           "Like move, but each object's box becomes the union of its previous box and the new one (both grown "
           "by its margin): the candidates of a continuous collision test. The previous box is the one given "
           "to its last move_swept (sweeps do not accumulate), or its box after a plain move.")
      .def("reserve", &PyBroadPhase::reserve, py::arg("objects"),
           "Provisions memory for up to `objects` moving objects before they are added, so the first update() "
           "does not pay for fresh memory (optional; results are the same).")
      .def("move", &PyBroadPhase::move, py::arg("handles"), py::arg("boxes"),
           "Replaces the boxes of handles ((m,) integers) with boxes ((m, 6) float32; float64 on a double_precision "
           "BroadPhase).")
      .def("remove", &PyBroadPhase::remove, py::arg("handles"),
           "Removes the objects of handles ((m,) integers); their pairs are reported removed at the next update(). "
           "ValueError naming the row of an unknown, stale or repeated handle.")
      .def("set_layer", &PyBroadPhase::set_layer, py::arg("handles"), py::arg("layer"),
           "Moves the objects of handles ((m,) integers) to layer (0..LAYER_COUNT - 1).")
      .def("set_static", &PyBroadPhase::set_static, py::arg("handles"), py::arg("static"),
           "Makes the objects of handles ((m,) integers) static (static=True: bodies going to sleep, costing what "
           "a static object costs) or moving (False: waking), keeping their handles, boxes and layers; objects "
           "already of that kind stay. At the next update() a pair reported before and after (one object still "
           "moving) is neither created nor removed; a pair of two objects now static is removed, and created "
           "again when one wakes. ValueError naming the row of an unknown, stale or repeated handle.")
      .def("snapshot", &PyBroadPhase::snapshot,
           "The whole logical state as bytes: objects (handles, kinds, layers, boxes), the order free slots are "
           "reused in, the layer table, the last update's pairs and the edits since. restore() or "
           "from_snapshot() of it gives a broad phase whose next updates and new handles are this one's. "
           "Not held: the options and the pair filter.")
      .def("restore", &PyBroadPhase::restore, py::arg("data"),
           "Replaces the state with a snapshot's (bytes-like); the options and the pair filter stay. ValueError "
           "naming what is wrong with malformed, truncated, corrupted or wrong-version data, the object unchanged.")
      .def("set_collides", &PyBroadPhase::set_collides, py::arg("layer_a"), py::arg("layer_b"),
           py::arg("collides"), "Symmetric; every pair of layers collides by default.")
      .def("collides", &PyBroadPhase::collides, py::arg("layer_a"), py::arg("layer_b"),
           "Whether objects of layer_a and layer_b are paired (set_collides).")
      .def("set_pair_filter", &PyBroadPhase::set_pair_filter, py::arg("filter"),
           "f(a, b) -> bool called for pairs passing the box and layer tests (a < b); None removes it. "
           "Runs under the GIL from worker threads (serialised).")
      .def("update", &PyBroadPhase::update,
           "Applies every edit since the last update and returns an UpdateResult: pairs (every reported pair "
           "now), created (new since the previous update) and removed (gone since then), each a (k, 2) uint32 "
           "array of handles, a < b, sorted. A pair needs overlapping boxes, at least one moving object, "
           "colliding layers and the pair filter's consent. Raises CapacityExceeded past max_pairs, or what "
           "the pair filter raised; a raising update() applies nothing.")
      .def("set_filter", &PyBroadPhase::set_filter, py::arg("handles"), py::kw_only(), py::arg("category") = 1,
           py::arg("mask") = py::int_(~std::uint64_t{0}), py::arg("group") = 0,
           "Gives the objects the filter (category, mask: 64-bit ints; group: signed 32-bit). Two objects pair "
           "when they share a nonzero group: always if positive, never if negative; otherwise when each one's "
           "category meets the other's mask. Applied with the layer table before a pair is stored.")
      .def("filter", &PyBroadPhase::filter, py::arg("handle"), "The object's filter as (category, mask, group).")
      .def("set_user_data", &PyBroadPhase::set_user_data, py::arg("handles"), py::arg("values"),
           "One 64-bit int per handle, kept with the object.")
      .def("user_data", &PyBroadPhase::user_data, py::arg("handle"), "The object's user data (an int).")
      .def("pair_user_data", &PyBroadPhase::pair_user_data, py::arg("pairs"),
           "The user data of a (k, 2) array of handle pairs (e.g. update().created) as (k, 2) uint64; 0 for "
           "an object no longer live (a removed pair's object removed since).")
      .def("query_box", &PyBroadPhase::query_box, py::arg("box"), py::kw_only(),
           py::arg("layers_mask") = py::int_(0xFFFFFFFFu), py::arg("category_mask") = py::int_(~std::uint64_t{0}),
           "Handles whose box overlaps the closed box, sorted: a (6,) float32 array, or a list or tuple of 6 "
           "numbers (each rounded to the nearest float32). Sees every edit, updated or not. layers_mask, "
           "category_mask (every query): only objects whose layer bit is in layers_mask and whose category "
           "meets category_mask.")
      .def("query_boxes", &PyBroadPhase::query_boxes, py::arg("boxes"),
           "query_box for each row of (m, 6) float32 boxes: (offsets (m + 1,) int64, handles); row i's hits "
           "are handles[offsets[i]:offsets[i + 1]], sorted.")
      .def("query_ray", &PyBroadPhase::query_ray, py::arg("origin"), py::arg("direction"), py::arg("max_t"),
           py::kw_only(), py::arg("layers_mask") = py::int_(0xFFFFFFFFu),
           py::arg("category_mask") = py::int_(~std::uint64_t{0}),
           "Handles whose box the segment origin + t * direction, 0 <= t <= max_t, touches, by entry t (0 "
           "when origin is inside), ties by handle. origin, direction: (3,) float32 arrays or lists or tuples "
           "of 3 numbers; max_t >= 0, inf for the whole ray.")
      .def("raycast_closest", &PyBroadPhase::raycast_closest, py::arg("origin"), py::arg("direction"),
           py::arg("max_t"), py::kw_only(), py::arg("layers_mask") = py::int_(0xFFFFFFFFu),
           py::arg("category_mask") = py::int_(~std::uint64_t{0}),
           "query_ray's first hit as (handle, t): the smallest entry t (0 when origin is inside), ties by "
           "handle; None when the segment touches nothing. Walks nearest-first and skips what lies beyond the "
           "best hit so far. Same arguments as query_ray.")
      .def("box_cast", &PyBroadPhase::box_cast, py::arg("box"), py::arg("displacement"), py::kw_only(),
           py::arg("layers_mask") = py::int_(0xFFFFFFFFu), py::arg("category_mask") = py::int_(~std::uint64_t{0}),
           "Handles whose box the moving box box + t * displacement, 0 <= t <= 1, touches, by the first such t, "
           "ties by handle (uint32 array). box as for query_box, displacement a (3,) float32 array or 3 "
           "numbers; a zero displacement gives query_box(box).")
      .def("__len__", &PyBroadPhase::size, "The number of live objects.")
      .def("__contains__", &PyBroadPhase::contains, py::arg("handle"), "`handle in bp`: whether handle is a live object.")
      .def("contains", &PyBroadPhase::contains, py::arg("handle"),
           "Whether handle is a live object (False for removed, stale or non-integer handles).")
      .def("box", &PyBroadPhase::box, py::arg("handle"),
           "The object's box as a (6,) float32 array, float64 on a double_precision BroadPhase (ValueError for an "
           "unknown or stale handle).")
      .def("is_static", &PyBroadPhase::is_static, py::arg("handle"),
           "Whether the object was added with static=True.")
      .def("layer", &PyBroadPhase::layer, py::arg("handle"), "The object's layer (0..LAYER_COUNT - 1).")
      .def_property_readonly("stats", &PyBroadPhase::stats,
                             "The last update(): dict of moving, statics (live objects), moved, static_changes "
                             "(objects changed since the update before) and wall_ms (its wall time).")
      .def_property_readonly("engine", [](const PyBroadPhase& b) { return b.options().engine; },
                             "The cell engine's name.")
      .def_property_readonly("threads", [](const PyBroadPhase& b) { return b.options().threads; },
                             "The thread count asked for (0: all cores).")
      .def_property_readonly("cell_limit", [](const PyBroadPhase& b) { return b.options().cell_limit; },
                             "The partition's objects per cell (0: the engine's default).")
      .def_property_readonly("max_pairs", [](const PyBroadPhase& b) { return b.options().max_pairs; },
                             "The most pairs one update() may report (0: unlimited).")
      .def("__repr__", [](PyBroadPhase& b) {
        return "BroadPhase(engine='" + b.options().engine + "', objects=" + std::to_string(b.size()) + ")";
      }, "The engine and the number of live objects.");
  // A classmethod: cls(**options), then restore(data) (a subclass gets an
  // instance of itself).
  broad_phase.attr("from_snapshot") = py::reinterpret_steal<py::object>(PyClassMethod_New(
      py::cpp_function(
          [](const py::object& cls, const py::object& data, const std::string& engine, const py::object& threads,
             long long cell_limit, long long max_pairs, const py::object& double_precision) {
            // The precision is the snapshot's; one given must match it.
            std::optional<hbp::BroadPhase> made;
            PyBroadPhase::with_bytes(data, "from_snapshot", [&](std::span<const std::byte> bytes) {
              made.emplace(hbp::BroadPhase::from_snapshot(bytes, make_options(engine, threads, cell_limit, max_pairs)));
            });
            const bool doubles = made->options().double_precision;
            if (!double_precision.is_none() && double_precision.cast<bool>() != doubles)
              throw ArgumentError(std::string("from_snapshot: double_precision=") +
                                  (doubles ? "False" : "True") + " but the snapshot is of a " +
                                  (doubles ? "double_precision" : "float") + " broad phase");
            py::object bp = cls(py::arg("engine") = engine, py::arg("threads") = threads,
                                py::arg("cell_limit") = cell_limit, py::arg("max_pairs") = max_pairs,
                                py::arg("double_precision") = doubles);
            bp.cast<PyBroadPhase&>().adopt(std::move(*made));
            return bp;
          },
          py::name("from_snapshot"), py::arg("cls"), py::arg("data"), py::kw_only(), py::arg("engine") = "sw",
          py::arg("threads") = 0, py::arg("cell_limit") = 0, py::arg("max_pairs") = 0,
          py::arg("double_precision") = py::none(),
          "A new BroadPhase (of the class it is called on) with the options given and a snapshot's state "
          "(bytes-like, from snapshot()); its double_precision is the snapshot's (one given must match). "
          "ValueError for malformed data, as restore().")
          .ptr()));
}
