// SPDX-License-Identifier: MIT
// The C API (hbp/hbp.h) over hbp::BroadPhase. Every entry point catches
// everything: a C++ exception becomes a status and a thread-local message.
#include "hbp/hbp.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <new>
#include <optional>
#include <span>
#include <thread>
#include <string>
#include <type_traits>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/aabb_d.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "hbp/limits.hpp"
#include "hbp/pair.hpp"
#include "hbp/task_system.hpp"

#ifndef HBP_VERSION_STRING
#error "HBP_VERSION_STRING is set by CMakeLists.txt"
#endif

// The C structs are the C++ ones, member for member: arrays pass through
// without copies.
static_assert(std::is_standard_layout_v<hbp_box> && std::is_standard_layout_v<hbp::Aabb>);
static_assert(sizeof(hbp_box) == sizeof(hbp::Aabb) && offsetof(hbp_box, max) == offsetof(hbp::Aabb, max));
static_assert(std::is_standard_layout_v<hbp_box_d> && std::is_standard_layout_v<hbp::AabbD>);
static_assert(sizeof(hbp_box_d) == sizeof(hbp::AabbD) && offsetof(hbp_box_d, max) == offsetof(hbp::AabbD, max));
static_assert(std::is_standard_layout_v<hbp_pair> && std::is_standard_layout_v<hbp::Pair>);
static_assert(sizeof(hbp_pair) == sizeof(hbp::Pair) && offsetof(hbp_pair, b) == offsetof(hbp::Pair, b));
static_assert(std::is_same_v<hbp_handle, hbp::Handle> && HBP_INVALID_HANDLE == hbp::kInvalidHandle);
static_assert(HBP_MAX_OBJECTS == hbp::kMaxObjects && HBP_LAYER_COUNT == hbp::kLayerCount);

// hbp_options::run_tasks as the engine's task system. The library's task
// functions are hbp_task_fn's: same signature, and they never throw.
class CallbackTaskSystem final : public hbp::TaskSystem {
 public:
  CallbackTaskSystem(hbp_run_tasks_fn run, void* user, std::uint32_t threads)
      : run_(run), user_(user), threads_(threads ? threads : std::max(1u, std::thread::hardware_concurrency())) {}
  void run(std::uint32_t task_count, hbp::TaskFunction fn, void* context) override {
    run_(user_, task_count, fn, context);
  }
  unsigned concurrency() const override { return threads_; }

 private:
  hbp_run_tasks_fn run_;
  void* user_;
  unsigned threads_;
};

struct hbp_broad_phase {
  std::optional<CallbackTaskSystem> tasks;  // outlives bp (declared first)
  hbp::BroadPhase bp;
  explicit hbp_broad_phase(const hbp::BroadPhaseOptions& options) : bp(options) {}
  hbp_broad_phase(const hbp::BroadPhaseOptions& options, hbp_run_tasks_fn run, void* user)
      : tasks(std::in_place, run, user, options.threads), bp(with_tasks(options, &*tasks)) {}

 private:
  static hbp::BroadPhaseOptions with_tasks(hbp::BroadPhaseOptions o, hbp::TaskSystem* tasks) {
    o.task_system = tasks;
    return o;
  }
};

namespace {

thread_local std::string last_error;

hbp_status fail(hbp_status status, const char* message) noexcept {
  try {
    last_error = message;
  } catch (...) {
    last_error.clear();  // no memory for the message: the status still says what happened
  }
  return status;
}

hbp_status ok() noexcept {
  last_error.clear();
  return HBP_OK;
}

// Runs f (returning hbp_status), mapping every exception to a status.
template <class F>
hbp_status guarded(F&& f) noexcept {
  try {
    return f();
  } catch (const hbp::InvalidInput& e) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, e.what());
  } catch (const hbp::CapacityExceeded& e) {
    return fail(HBP_ERROR_CAPACITY, e.what());
  } catch (const std::bad_alloc&) {
    return fail(HBP_ERROR_OUT_OF_MEMORY, "out of memory");
  } catch (const std::exception& e) {
    return fail(HBP_ERROR_INTERNAL, e.what());
  } catch (...) {
    return fail(HBP_ERROR_INTERNAL, "unknown C++ exception");
  }
}

const hbp::Aabb* as_aabbs(const hbp_box* boxes) { return reinterpret_cast<const hbp::Aabb*>(boxes); }
const hbp::AabbD* as_aabbs(const hbp_box_d* boxes) { return reinterpret_cast<const hbp::AabbD*>(boxes); }

hbp_status pair_list(const hbp_broad_phase* bp, const hbp_pair** pairs, std::size_t* count, const char* function,
                     const std::vector<hbp::Pair> hbp::BroadPhaseUpdate::*list) {
  if (bp == nullptr || pairs == nullptr || count == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT,
                (std::string(function) + ": bp, pairs and count must not be NULL").c_str());
  }
  const std::vector<hbp::Pair>& v = bp->bp.last_update().*list;
  *pairs = v.empty() ? nullptr : reinterpret_cast<const hbp_pair*>(v.data());
  *count = v.size();
  return ok();
}

// The C callback as the query's visitor: hits in the query's order until the
// callback returns 0, with no list of hits built for the caller.
hbp::BroadPhase::HitVisitor c_visitor(hbp_hit_callback callback, void* user) {
  return [callback, user](hbp::Handle h) { return callback(user, h) != 0; };
}

hbp_status report_calls(std::size_t calls, std::size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = calls;
  return ok();
}

hbp::QueryFilter as_query_filter(const hbp_query_filter* f) {
  return f ? hbp::QueryFilter{f->layers_mask, f->category_mask} : hbp::QueryFilter{};
}

}  // namespace

extern "C" {

const char* hbp_version(void) { return HBP_VERSION_STRING; }

const char* hbp_status_string(hbp_status status) {
  switch (status) {
    case HBP_OK: return "ok";
    case HBP_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case HBP_ERROR_CAPACITY: return "capacity exceeded";
    case HBP_ERROR_OUT_OF_MEMORY: return "out of memory";
    case HBP_ERROR_INTERNAL: return "internal error";
  }
  return "unknown status";
}

const char* hbp_last_error(void) { return last_error.c_str(); }

void hbp_options_init(hbp_options* options) {
  if (options == nullptr) return;
  options->engine = nullptr;
  options->threads = 0;
  options->cell_limit = 0;
  options->max_pairs = 0;
  options->run_tasks = nullptr;
  options->task_user = nullptr;
  options->double_precision = 0;
}

hbp_status hbp_create(const hbp_options* options, hbp_broad_phase** out) {
  if (out == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_create: out must not be NULL");
  *out = nullptr;
  return guarded([&] {
    hbp::BroadPhaseOptions o;
    if (options != nullptr) {
      if (options->engine != nullptr) o.engine = options->engine;
      o.threads = options->threads;
      o.cell_limit = options->cell_limit;
      o.max_pairs = options->max_pairs;
      o.double_precision = options->double_precision != 0;
    }
    // (threads above the limit: InvalidInput from the broad phase, either way)
    if (options != nullptr && options->run_tasks != nullptr)
      *out = new hbp_broad_phase(o, options->run_tasks, options->task_user);
    else
      *out = new hbp_broad_phase(o);
    return ok();
  });
}

void hbp_destroy(hbp_broad_phase* bp) { delete bp; }

hbp_status hbp_add(hbp_broad_phase* bp, const hbp_box* boxes, size_t count, int is_static, uint8_t layer,
                   hbp_handle* handles_out) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_add: bp must not be NULL");
  if (count > 0 && (boxes == nullptr || handles_out == nullptr)) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_add: boxes and handles_out must not be NULL when count > 0");
  }
  return guarded([&] {
    const std::vector<hbp::Handle> handles =
        bp->bp.add(std::span<const hbp::Aabb>(as_aabbs(boxes), count), {.is_static = is_static != 0, .layer = layer});
    for (std::size_t i = 0; i < handles.size(); ++i) handles_out[i] = handles[i];
    return ok();
  });
}

hbp_status hbp_move(hbp_broad_phase* bp, const hbp_handle* handles, const hbp_box* boxes, size_t count) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_move: bp must not be NULL");
  if (count > 0 && (boxes == nullptr || handles == nullptr)) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_move: handles and boxes must not be NULL when count > 0");
  }
  return guarded([&] {
    bp->bp.move(std::span<const hbp::Handle>(handles, count), std::span<const hbp::Aabb>(as_aabbs(boxes), count));
    return ok();
  });
}

hbp_status hbp_remove(hbp_broad_phase* bp, const hbp_handle* handles, size_t count) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_remove: bp must not be NULL");
  if (count > 0 && handles == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_remove: handles must not be NULL when count > 0");
  }
  return guarded([&] {
    bp->bp.remove(std::span<const hbp::Handle>(handles, count));
    return ok();
  });
}

hbp_status hbp_set_collides(hbp_broad_phase* bp, uint32_t layer_a, uint32_t layer_b, int collides) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_set_collides: bp must not be NULL");
  return guarded([&] {
    bp->bp.set_collides(layer_a, layer_b, collides != 0);
    return ok();
  });
}

hbp_status hbp_update(hbp_broad_phase* bp) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_update: bp must not be NULL");
  return guarded([&] {
    bp->bp.update();
    return ok();
  });
}

hbp_status hbp_pairs(const hbp_broad_phase* bp, const hbp_pair** pairs, size_t* count) {
  return pair_list(bp, pairs, count, "hbp_pairs", &hbp::BroadPhaseUpdate::pairs);
}

hbp_status hbp_created_pairs(const hbp_broad_phase* bp, const hbp_pair** pairs, size_t* count) {
  return pair_list(bp, pairs, count, "hbp_created_pairs", &hbp::BroadPhaseUpdate::created);
}

hbp_status hbp_removed_pairs(const hbp_broad_phase* bp, const hbp_pair** pairs, size_t* count) {
  return pair_list(bp, pairs, count, "hbp_removed_pairs", &hbp::BroadPhaseUpdate::removed);
}

hbp_status hbp_query_box(const hbp_broad_phase* bp, const hbp_box* box, hbp_hit_callback callback, void* user,
                         size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = 0;
  if (bp == nullptr || box == nullptr || callback == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_query_box: bp, box and callback must not be NULL");
  }
  return guarded([&] { return report_calls(bp->bp.query_box(*as_aabbs(box), c_visitor(callback, user)), hits_out); });
}

hbp_status hbp_query_ray(const hbp_broad_phase* bp, const float origin[3], const float direction[3], float max_t,
                         hbp_hit_callback callback, void* user, size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = 0;
  if (bp == nullptr || origin == nullptr || direction == nullptr || callback == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_query_ray: bp, origin, direction and callback must not be NULL");
  }
  return guarded([&] {
    const hbp::BroadPhase::Vec3f o{origin[0], origin[1], origin[2]}, d{direction[0], direction[1], direction[2]};
    return report_calls(bp->bp.query_ray(o, d, max_t, c_visitor(callback, user)), hits_out);
  });
}

hbp_status hbp_raycast_closest_filtered(const hbp_broad_phase* bp, const float origin[3], const float direction[3],
                                        float max_t, const hbp_query_filter* filter, hbp_handle* handle_out,
                                        float* t_out, int* hit_out) {
  if (bp == nullptr || origin == nullptr || direction == nullptr || handle_out == nullptr || t_out == nullptr ||
      hit_out == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT,
                "hbp_raycast_closest: bp, origin, direction, handle_out, t_out and hit_out must not be NULL");
  }
  *handle_out = HBP_INVALID_HANDLE;
  *t_out = 0.0f;
  *hit_out = 0;
  return guarded([&] {
    const hbp::BroadPhase::Vec3f o{origin[0], origin[1], origin[2]}, d{direction[0], direction[1], direction[2]};
    if (const std::optional<hbp::RayHit> hit = bp->bp.raycast_closest(o, d, max_t, as_query_filter(filter))) {
      *handle_out = hit->handle;
      *t_out = hit->t;
      *hit_out = 1;
    }
    return ok();
  });
}

hbp_status hbp_raycast_closest(const hbp_broad_phase* bp, const float origin[3], const float direction[3], float max_t,
                               hbp_handle* handle_out, float* t_out, int* hit_out) {
  return hbp_raycast_closest_filtered(bp, origin, direction, max_t, nullptr, handle_out, t_out, hit_out);
}

hbp_status hbp_box_cast_filtered(const hbp_broad_phase* bp, const hbp_box* box, const float displacement[3],
                                 const hbp_query_filter* filter, hbp_hit_callback callback, void* user,
                                 size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = 0;
  if (bp == nullptr || box == nullptr || displacement == nullptr || callback == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_box_cast: bp, box, displacement and callback must not be NULL");
  }
  return guarded([&] {
    const hbp::BroadPhase::Vec3f d{displacement[0], displacement[1], displacement[2]};
    return report_calls(
        bp->bp.query_box_cast(*as_aabbs(box), d, c_visitor(callback, user), as_query_filter(filter)), hits_out);
  });
}

hbp_status hbp_box_cast(const hbp_broad_phase* bp, const hbp_box* box, const float displacement[3],
                        hbp_hit_callback callback, void* user, size_t* hits_out) {
  return hbp_box_cast_filtered(bp, box, displacement, nullptr, callback, user, hits_out);
}

hbp_status hbp_query_box_filtered(const hbp_broad_phase* bp, const hbp_box* box, const hbp_query_filter* filter,
                                  hbp_hit_callback callback, void* user, size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = 0;
  if (bp == nullptr || box == nullptr || callback == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_query_box: bp, box and callback must not be NULL");
  }
  return guarded([&] {
    return report_calls(bp->bp.query_box(*as_aabbs(box), c_visitor(callback, user), as_query_filter(filter)),
                        hits_out);
  });
}

hbp_status hbp_query_ray_filtered(const hbp_broad_phase* bp, const float origin[3], const float direction[3],
                                  float max_t, const hbp_query_filter* filter, hbp_hit_callback callback, void* user,
                                  size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = 0;
  if (bp == nullptr || origin == nullptr || direction == nullptr || callback == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_query_ray: bp, origin, direction and callback must not be NULL");
  }
  return guarded([&] {
    const hbp::BroadPhase::Vec3f o{origin[0], origin[1], origin[2]}, d{direction[0], direction[1], direction[2]};
    return report_calls(bp->bp.query_ray(o, d, max_t, c_visitor(callback, user), as_query_filter(filter)), hits_out);
  });
}

hbp_status hbp_set_margin(hbp_broad_phase* bp, const hbp_handle* handles, size_t count, float margin) {
  if (bp == nullptr || (count > 0 && handles == nullptr)) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_set_margin: bp must not be NULL, nor handles when count > 0");
  }
  return guarded([&] {
    bp->bp.set_margin(std::span<const hbp::Handle>(handles, count), margin);
    return ok();
  });
}

hbp_status hbp_move_swept(hbp_broad_phase* bp, const hbp_handle* handles, const hbp_box* boxes, size_t count) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_move_swept: bp must not be NULL");
  if (count > 0 && (boxes == nullptr || handles == nullptr)) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_move_swept: handles and boxes must not be NULL when count > 0");
  }
  return guarded([&] {
    bp->bp.move_swept(std::span<const hbp::Handle>(handles, count), std::span<const hbp::Aabb>(as_aabbs(boxes), count));
    return ok();
  });
}

void hbp_filter_init(hbp_filter* filter) {
  if (filter == nullptr) return;
  const hbp::Filter d;
  filter->category = d.category;
  filter->mask = d.mask;
  filter->group = d.group;
}

void hbp_query_filter_init(hbp_query_filter* filter) {
  if (filter == nullptr) return;
  const hbp::QueryFilter d;
  filter->layers_mask = d.layers_mask;
  filter->category_mask = d.category_mask;
}

hbp_status hbp_set_filter(hbp_broad_phase* bp, const hbp_handle* handles, size_t count, const hbp_filter* filter) {
  if (bp == nullptr || filter == nullptr || (count > 0 && handles == nullptr)) {
    return fail(HBP_ERROR_INVALID_ARGUMENT,
                "hbp_set_filter: bp and filter must not be NULL, nor handles when count > 0");
  }
  return guarded([&] {
    bp->bp.set_filter(std::span<const hbp::Handle>(handles, count), {filter->category, filter->mask, filter->group});
    return ok();
  });
}

hbp_status hbp_get_filter(const hbp_broad_phase* bp, hbp_handle handle, hbp_filter* filter_out) {
  if (bp == nullptr || filter_out == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_get_filter: bp and filter_out must not be NULL");
  }
  return guarded([&] {
    const hbp::Filter f = bp->bp.filter(handle);
    filter_out->category = f.category;
    filter_out->mask = f.mask;
    filter_out->group = f.group;
    return ok();
  });
}

hbp_status hbp_set_user_data(hbp_broad_phase* bp, const hbp_handle* handles, const uint64_t* values, size_t count) {
  if (bp == nullptr || (count > 0 && (handles == nullptr || values == nullptr))) {
    return fail(HBP_ERROR_INVALID_ARGUMENT,
                "hbp_set_user_data: bp must not be NULL, nor handles and values when count > 0");
  }
  return guarded([&] {
    bp->bp.set_user_data(std::span<const hbp::Handle>(handles, count), std::span<const std::uint64_t>(values, count));
    return ok();
  });
}

hbp_status hbp_get_user_data(const hbp_broad_phase* bp, hbp_handle handle, uint64_t* value_out) {
  if (bp == nullptr || value_out == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_get_user_data: bp and value_out must not be NULL");
  }
  return guarded([&] {
    *value_out = bp->bp.user_data(handle);
    return ok();
  });
}

hbp_status hbp_pair_user_data(const hbp_broad_phase* bp, const hbp_pair* pairs, size_t count, uint64_t* out) {
  if (bp == nullptr || (count > 0 && (pairs == nullptr || out == nullptr))) {
    return fail(HBP_ERROR_INVALID_ARGUMENT,
                "hbp_pair_user_data: bp must not be NULL, nor pairs and out when count > 0");
  }
  return guarded([&] {
    for (size_t i = 0; i < count; ++i) {
      const hbp::Handle h[2] = {pairs[i].a, pairs[i].b};
      std::uint64_t v[2];
      bp->bp.user_data(std::span<const hbp::Handle>(h, 2), std::span<std::uint64_t>(v, 2));
      out[2 * i] = v[0];
      out[2 * i + 1] = v[1];
    }
    return ok();
  });
}

hbp_status hbp_size(const hbp_broad_phase* bp, size_t* count) {
  if (bp == nullptr || count == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_size: bp and count must not be NULL");
  }
  *count = bp->bp.size();
  return ok();
}

hbp_status hbp_get_box(const hbp_broad_phase* bp, hbp_handle handle, hbp_box* box_out) {
  if (bp == nullptr || box_out == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_get_box: bp and box_out must not be NULL");
  }
  return guarded([&] {
    const hbp::Aabb b = bp->bp.box(handle);
    for (int i = 0; i < 3; ++i) {
      box_out->min[i] = b.min[i];
      box_out->max[i] = b.max[i];
    }
    return ok();
  });
}

int hbp_contains(const hbp_broad_phase* bp, hbp_handle handle) {
  if (bp == nullptr) return 0;
  try {
    return bp->bp.contains(handle) ? 1 : 0;
  } catch (...) {
    return 0;
  }
}

// ---- large worlds ----------------------------------------------------------

hbp_status hbp_shift_origin(hbp_broad_phase* bp, const double offset[3]) {
  if (bp == nullptr || offset == nullptr)
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_shift_origin: bp and offset must not be NULL");
  return guarded([&] {
    bp->bp.shift_origin_d({offset[0], offset[1], offset[2]});
    return ok();
  });
}

hbp_status hbp_add_d(hbp_broad_phase* bp, const hbp_box_d* boxes, size_t count, int is_static, uint8_t layer,
                     hbp_handle* handles_out) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_add_d: bp must not be NULL");
  if (count > 0 && (boxes == nullptr || handles_out == nullptr))
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_add_d: boxes and handles_out must not be NULL when count > 0");
  return guarded([&] {
    const std::vector<hbp::Handle> handles = bp->bp.add(std::span<const hbp::AabbD>(as_aabbs(boxes), count),
                                                        {.is_static = is_static != 0, .layer = layer});
    std::copy(handles.begin(), handles.end(), handles_out);
    return ok();
  });
}

hbp_status hbp_move_d(hbp_broad_phase* bp, const hbp_handle* handles, const hbp_box_d* boxes, size_t count) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_move_d: bp must not be NULL");
  if (count > 0 && (boxes == nullptr || handles == nullptr))
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_move_d: handles and boxes must not be NULL when count > 0");
  return guarded([&] {
    bp->bp.move(std::span<const hbp::Handle>(handles, count), std::span<const hbp::AabbD>(as_aabbs(boxes), count));
    return ok();
  });
}

hbp_status hbp_get_box_d(const hbp_broad_phase* bp, hbp_handle handle, hbp_box_d* box_out) {
  if (bp == nullptr || box_out == nullptr)
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_get_box_d: bp and box_out must not be NULL");
  return guarded([&] {
    const hbp::AabbD b = bp->bp.box_d(handle);
    for (int i = 0; i < 3; ++i) {
      box_out->min[i] = b.min[i];
      box_out->max[i] = b.max[i];
    }
    return ok();
  });
}

hbp_status hbp_query_box_d(const hbp_broad_phase* bp, const hbp_box_d* box, hbp_hit_callback callback, void* user,
                           size_t* hits_out) {
  if (hits_out != nullptr) *hits_out = 0;
  if (bp == nullptr || box == nullptr || callback == nullptr)
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_query_box_d: bp, box and callback must not be NULL");
  return guarded([&] { return report_calls(bp->bp.query_box(*as_aabbs(box), c_visitor(callback, user)), hits_out); });
}

hbp_status hbp_set_static(hbp_broad_phase* bp, const hbp_handle* handles, size_t count, int is_static) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_set_static: bp must not be NULL");
  if (count > 0 && handles == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_set_static: handles must not be NULL when count > 0");
  }
  return guarded([&] {
    bp->bp.set_static(std::span<const hbp::Handle>(handles, count), is_static != 0);
    return ok();
  });
}

hbp_status hbp_snapshot_size(const hbp_broad_phase* bp, size_t* size_out) {
  if (bp == nullptr || size_out == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_snapshot_size: bp and size_out must not be NULL");
  }
  return guarded([&] {
    *size_out = bp->bp.snapshot_size();
    return ok();
  });
}

hbp_status hbp_snapshot(const hbp_broad_phase* bp, void* buffer, size_t capacity, size_t* size_out) {
  if (bp == nullptr || size_out == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_snapshot: bp and size_out must not be NULL");
  }
  if (capacity > 0 && buffer == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_snapshot: buffer must not be NULL when capacity > 0");
  }
  return guarded([&] {
    const std::size_t need = bp->bp.snapshot_size();
    *size_out = need;
    if (capacity < need) {
      return fail(HBP_ERROR_CAPACITY, ("hbp_snapshot: a buffer of " + std::to_string(capacity) +
                                       " bytes, the snapshot needs " + std::to_string(need) +
                                       " (hbp_snapshot_size)").c_str());
    }
    bp->bp.snapshot(std::span<std::byte>(static_cast<std::byte*>(buffer), capacity));
    return ok();
  });
}

hbp_status hbp_restore(hbp_broad_phase* bp, const void* data, size_t size) {
  if (bp == nullptr) return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_restore: bp must not be NULL");
  if (size > 0 && data == nullptr) {
    return fail(HBP_ERROR_INVALID_ARGUMENT, "hbp_restore: data must not be NULL when size > 0");
  }
  return guarded([&] {
    bp->bp.restore(std::span<const std::byte>(static_cast<const std::byte*>(data), size));
    return ok();
  });
}

}  // extern "C"
