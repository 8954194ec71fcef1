// SPDX-License-Identifier: MIT
// The GPU frame on a CUDA device: the stages of host_frame.cpp as kernels
// (device_kernels.cu) and CUB scans and radix sorts on one stream. Three
// small read-backs per frame size what follows (bounds -> grid; reference
// count; pair count -> max_pairs check and the pair buffer), so nothing is
// ever truncated. Buffers are kept across frames (device_support.cuh).
#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include "cuda/device_kernels.cuh"
#include "cuda/device_primitives.cuh"
#include "cuda/device_support.cuh"
#include "cuda/frame_impl.hpp"
#include "cuda/grid_plan.hpp"

namespace hbp::cuda {

int require_device() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess || count == 0) {
    cudaGetLastError();  // clear the sticky error of a missing driver or device
    throw Error("no CUDA device found (the \"cuda\" engine and Launcher::Device need an NVIDIA GPU; "
                "\"cuda-host\" runs the same kernels on the CPU)");
  }
  int device = 0;
  check_cuda(cudaGetDevice(&device), "cudaGetDevice");
  return device;
}

void check_on_device(const void* data, int device, const char* what) {
  cudaPointerAttributes a{};
  if (cudaPointerGetAttributes(&a, data) != cudaSuccess) {
    cudaGetLastError();  // not the launches' to report
    return;
  }
  if (a.type == cudaMemoryTypeDevice && a.device != device)
    throw InvalidInput(std::string(what) + " lie in the memory of CUDA device " + std::to_string(a.device) +
                       ", the frame runs on device " + std::to_string(device) +
                       " (the device current when it was made)");
}

void check_stream_on_device(void* stream, int device) {
  int stream_device = device;
  if (cudaStreamGetDevice(static_cast<cudaStream_t>(stream), &stream_device) != cudaSuccess) {
    cudaGetLastError();  // an invalid handle is the launches' to report
    return;
  }
  if (stream_device != device)
    throw InvalidInput("the CUDA stream belongs to device " + std::to_string(stream_device) +
                       ", the frame runs on device " + std::to_string(device) +
                       " (the device current when it was made)");
}

bool device_available() {
  int count = 0;
  const bool ok = cudaGetDeviceCount(&count) == cudaSuccess && count > 0;
  cudaGetLastError();
  return ok;
}

std::string device_name() {
  if (!device_available()) return "";
  cudaDeviceProp p{};
  if (cudaGetDeviceProperties(&p, 0) != cudaSuccess) return "";
  return p.name;
}

namespace {

float from_ordered(std::uint32_t u) {
  const std::uint32_t bits = (u & 0x80000000u) ? (u & 0x7fffffffu) : ~u;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

enum Stage { kStart, kUploaded, kBounds, kRefs, kSorted, kCounted, kFilled, kOrdered, kDownloaded, kStages };

class DeviceFrame final : public FrameBroadPhase::Impl {
 public:
  explicit DeviceFrame(const FrameOptions& o) : Impl(o), device_(require_device()) {
    check_cuda(cudaStreamCreateWithFlags(&own_stream_, cudaStreamNonBlocking), "cudaStreamCreate");
    for (auto& e : events_) check_cuda(cudaEventCreate(&e), "cudaEventCreate");
    check_cuda(cudaMallocHost(&pinned_, (kScalars + 4) * sizeof(std::uint64_t)), "cudaMallocHost");
    scalars_ = pinned_ + kScalars;
  }
  ~DeviceFrame() override {
    const DeviceScope scope(device_);
    for (auto& e : events_) cudaEventDestroy(e);
    cudaStreamDestroy(own_stream_);
    cudaFreeHost(pinned_);
  }

  void run(const Lanes& in) override { run_host(in, options.max_pairs); }

  void reserve(std::uint32_t n) override {
    const DeviceScope scope(device_);
    // Three overlapping boxes: a frame that launches the frame's kernels
    // (the large pass aside), so none is loaded in a timed frame. Its three
    // pairs are not the caller's: no pair limit (a max_pairs of 1 or 2
    // would refuse it).
    static const float lo[3] = {0, 0.25f, 0.5f}, hi[3] = {1, 1.25f, 1.5f};
    const Lanes tiny{{lo, lo, lo}, {hi, hi, hi}, 3};
    run_host(tiny, 0);
    grid_ = GridPlan();
    info = {};
    // The typical frame: about two references and under two pairs per
    // object (a frame that needs more grows its buffers then).
    const std::uint64_t refs = std::min<std::uint64_t>(2ull * n, 0xffffffffu);
    size_uploads(n);
    size_objects(n);
    // Cells: the grid's target count (grid_plan.hpp).
    const std::uint64_t cells = std::min<std::uint64_t>(n / options.boxes_per_cell + 1, kMaxCells);
    size_references(static_cast<std::uint32_t>(refs), 0, static_cast<std::uint32_t>(std::min(refs, cells)), refs);
    size_pairs(2ull * n, n);
    pairs.clear();  // no frame yet
    info = {};
  }

  // Host lanes in, host pairs out (update() and reserve's frame), with
  // `max_pairs` as the pair limit (0: none).
  void run_host(const Lanes& in, std::uint64_t max_pairs) {
    const DeviceScope scope(device_);
    info = {};
    stream_ = own_stream_;
    record(kStart);
    const std::uint32_t n = in.n;
    size_uploads(n);
    Lanes d{};
    d.n = n;
    for (int l = 0; l < 6; ++l) {
      float* lane = boxes_.as<float>() + static_cast<std::size_t>(l) * n;
      const float* src = l < 3 ? in.lo[l] : in.hi[l - 3];
      if (n) check_cuda(cudaMemcpyAsync(lane, src, n * sizeof(float), cudaMemcpyHostToDevice, stream_), "upload");
      (l < 3 ? d.lo[l] : d.hi[l - 3]) = lane;
    }
    record(kUploaded);
    const std::uint64_t count = frame(d, max_pairs);
    pairs.resize(count);
    if (count)
      check_cuda(cudaMemcpyAsync(pairs.data(), pair_buffer(), count * sizeof(Pair), cudaMemcpyDeviceToHost, stream_),
                 "download");
    record(kDownloaded);
    sync();
    times(true);
  }

  DevicePairs run_device(const DeviceRows& rows, void* stream) override {
    const DeviceScope scope(device_);
    if (rows.n) check_on_device(rows.data, device_, "boxes");
    begin_device(stream);
    const std::uint32_t n = rows.n;
    size_uploads(n);
    float* lanes = boxes_.as<float>();
    launch_rows_to_lanes(rows.data, rows.row_stride, rows.column_stride, n, lanes, stream_);
    Lanes d{};
    d.n = n;
    for (int k = 0; k < 3; ++k) {
      d.lo[k] = lanes + static_cast<std::size_t>(k) * n;
      d.hi[k] = lanes + static_cast<std::size_t>(3 + k) * n;
    }
    return finish_device(d, true);
  }

  DevicePairs run_device(const Lanes& in, void* stream) override {
    const DeviceScope scope(device_);
    if (in.n)
      for (int l = 0; l < 3; ++l) {
        check_on_device(in.lo[l], device_, "boxes");
        check_on_device(in.hi[l], device_, "boxes");
      }
    begin_device(stream);
    return finish_device(in, false);
  }

 private:
  const std::uint32_t* pair_buffer() const { return pair_out_.as<std::uint32_t>(); }

  // The device entries: the caller's stream (checked before any state
  // changes), the frame over device lanes, pairs left in pair_out_.
  // `transposed`: the lanes were made from rows on the device since
  // begin_device (timed as the upload).
  void begin_device(void* stream) {
    check_stream_on_device(stream, device_);
    info = {};
    stream_ = static_cast<cudaStream_t>(stream);
    record(kStart);
  }
  DevicePairs finish_device(const Lanes& lanes, bool transposed) {
    record(kUploaded);
    const std::uint64_t count = frame(lanes, options.max_pairs);
    record(kDownloaded);
    sync();
    times(false);
    if (transposed) info.times.upload_ms = between(kStart, kUploaded);
    pairs.clear();
    return {pair_buffer(), count};
  }

  // The stages bounds .. order over device lanes, CapacityExceeded past
  // `max_pairs` (0: no limit); returns the pair count, the pairs left in
  // pair_out_.
  std::uint64_t frame(const Lanes& in, std::uint64_t max_pairs) {
    const std::uint32_t n = in.n;
    const BoxLanesView b{{in.lo[0], in.lo[1], in.lo[2]}, {in.hi[0], in.hi[1], in.hi[2]}};

    // Bounds, extents and validation, read back with the reference count
    // below when the grid comes from the last frame (GridPlan::
    // update_from_last), else waited for here.
    reserve(acc_, kBoundsWords * sizeof(std::uint32_t));
    std::uint32_t* words = reinterpret_cast<std::uint32_t*>(pinned_);
    const std::uint32_t init[8] = {~0u, ~0u, ~0u, 0, 0, 0, n, 0};
    std::memcpy(words, init, sizeof init);
    std::memset(words + kBoundsExtents, 0, 3 * kExtentBins * sizeof(std::uint32_t));
    check_cuda(cudaMemcpyAsync(acc_.as<std::uint32_t>(), words, kBoundsWords * sizeof(std::uint32_t),
                               cudaMemcpyHostToDevice, stream_),
               "bounds init");
    size_objects(n);
    if (n) launch_bounds(b, n, acc_.as<std::uint32_t>(), stream_, packed_.as<float>());
    check_cuda(cudaMemcpyAsync(words, acc_.as<std::uint32_t>(), kBoundsWords * sizeof(std::uint32_t),
                               cudaMemcpyDeviceToHost, stream_),
               "bounds read-back");
    const bool lagged = grid_.update_from_last(n, options.boxes_per_cell, options.cell_shape, info.replanned);
    if (!lagged) {
      sync();
      info.replanned = grid_.update(take_bounds(b, n), extents_, n, options.boxes_per_cell, options.cell_shape);
    }
    reserve(planes_, 3 * kMaxAxisCells * sizeof(float));
    if (info.replanned && !grid_.planes().empty())
      check_cuda(cudaMemcpyAsync(planes_.as<float>(), grid_.planes().data(), grid_.planes().size() * sizeof(float),
                                 cudaMemcpyHostToDevice, stream_),
                 "planes upload");
    const GridView g = grid_.view(planes_.as<float>());
    for (int k = 0; k < 3; ++k) info.grid[k] = g.dims[k];
    record(kBounds);

    // References: count, scan, emit.
    launch_reference_count(g, b, n, ref_count_.as<std::uint64_t>(), is_large_.as<std::uint32_t>(), stream_);
    scan(ref_count_.as<std::uint64_t>(), ref_offset_.as<std::uint64_t>(), n);
    check_cuda(cudaMemcpyAsync(scalars_, ref_offset_.as<std::uint64_t>() + n, 8, cudaMemcpyDeviceToHost, stream_),
               "references");
    sync();
    if (lagged) take_bounds(b, n);
    const auto refs = static_cast<std::uint32_t>(scalars_[0] & 0xffffffffu);
    const auto large = static_cast<std::uint32_t>(scalars_[0] >> 32);
    info.references = refs;
    info.large = large;
    const std::uint32_t chunk = large_chunk(n, large);
    const std::uint32_t chunks = large ? (n + chunk - 1) / chunk : 0;
    const std::uint64_t slots = std::uint64_t{refs} + std::uint64_t{large} * chunks;
    const std::uint32_t max_cells = std::min(refs, grid_.cells());
    size_references(refs, large, max_cells, slots);
    const int bits = position_bits(grid_.cells());
    launch_emit(g, b, n, bits, is_large_.as<std::uint32_t>(), ref_offset_.as<std::uint64_t>(), keys_.as<std::uint32_t>(),
                ids_.as<std::uint32_t>(), large_list_.as<std::uint32_t>(), stream_);
    record(kRefs);

    // Sort by key (cell, position of min x) (stable), gather, cells.
    std::uint32_t* sorted_keys = nullptr;
    std::uint32_t* sorted_ids = nullptr;
    if (sort_pairs(keys_.as<std::uint32_t>(), keys_alt_.as<std::uint32_t>(), ids_.as<std::uint32_t>(),
                   ids_alt_.as<std::uint32_t>(), refs, key_bits(grid_.cells()), temp_, &sorted_keys, &sorted_ids,
                   stream_))
      ++info.allocations;
    check_cuda(cudaMemsetAsync(cells_.as<std::uint32_t>(), 0, 4, stream_), "cells");
    const bool per_reference = options.sweep == CellSweep::PerReference;
    if (per_reference) {
      // Its rows read their cells from the keys: lanes and the cell count only.
      launch_gather_lanes(packed_.as<float>(), sorted_keys, sorted_ids, refs, bits, lanes_.as<float>(),
                          cells_.as<std::uint32_t>(), stream_);
    } else {
      launch_gather_cells(packed_.as<float>(), sorted_keys, sorted_ids, refs, bits, lanes_.as<float>(),
                          positions_.as<std::uint32_t>(), head_.as<std::uint32_t>(), stream_);
      scan(head_.as<std::uint32_t>(), head_scan_.as<std::uint32_t>(), refs);
      // The scan is written to out[1..refs]: the cells kernel reads it from there.
      launch_cells(g, sorted_keys, bits, head_scan_.as<std::uint32_t>() + 1, refs, cell_begin_.as<std::uint32_t>(),
                   cell_ids_.as<std::uint32_t>(), regions_.as<CellRegion>(), cells_.as<std::uint32_t>(), stream_);
    }
    record(kSorted);

    // Count, scan.
    const float* lanes = lanes_.as<float>();
    const std::size_t stride = refs;
    const CellLanes s{{lanes, lanes + stride, lanes + 2 * stride},
                      {lanes + 3 * stride, lanes + 4 * stride, lanes + 5 * stride},
                      sorted_ids,
                      per_reference ? sorted_keys : positions_.as<std::uint32_t>()};
    std::uint64_t total = 0;
    std::uint32_t* out = nullptr;
    if (appending()) {
      // Counted and written in one pass (launch_append_rows), into room for
      // the last frame's pairs; a frame with more grows it and runs again.
      reserve(pair_out_, (last_total_ + 1) * 8);
      const auto append = [&] {
        out = pair_out_.as<std::uint32_t>();
        launch_append_rows(g, s, bits, refs, b, n, is_large_.as<std::uint32_t>(), large_list_.as<std::uint32_t>(),
                           large, chunk, total_.as<unsigned long long>(), pair_out_.capacity() / 8, out, stream_);
        read_counts(total_.as<std::uint64_t>());
        return scalars_[0];
      };
      total = append();
      record(kCounted);
      if (max_pairs && total > max_pairs) throw_too_many_pairs(total, max_pairs);
      if (total > pair_out_.capacity() / 8) {
        reserve(pair_out_, (total + 1) * 8);
        append();
      }
      record(kFilled);
    } else {
      std::uint64_t* counts = counts_.as<std::uint64_t>();
      const auto rows = [&](std::uint64_t* row_counts, const std::uint64_t* row_offsets, std::uint32_t* row_out) {
        if (per_reference)
          launch_reference_rows(g, s, bits, refs, kept_.as<RowPairs>(), row_counts, row_offsets, row_out, stream_);
        else
          launch_cell_rows(g, s, bits, cell_begin_.as<std::uint32_t>(), cell_ids_.as<std::uint32_t>(),
                           regions_.as<CellRegion>(), cells_.as<std::uint32_t>(), max_cells,
                           big_cells_.as<std::uint32_t>(), row_counts, row_offsets, row_out, stream_);
      };
      rows(counts, nullptr, nullptr);
      launch_large_rows(b, n, is_large_.as<std::uint32_t>(), large_list_.as<std::uint32_t>(), large, chunk,
                        counts + refs, nullptr, nullptr, stream_);
      scan(counts, offsets_.as<std::uint64_t>(), slots);
      read_counts(offsets_.as<std::uint64_t>() + slots);
      total = scalars_[0];
      record(kCounted);
      if (max_pairs && total > max_pairs) throw_too_many_pairs(total, max_pairs);

      // Fill.
      reserve(pair_out_, (total + 1) * 8);
      out = pair_out_.as<std::uint32_t>();
      const std::uint64_t* offsets = offsets_.as<std::uint64_t>();
      rows(nullptr, offsets, out);
      launch_large_rows(b, n, is_large_.as<std::uint32_t>(), large_list_.as<std::uint32_t>(), large, chunk, nullptr,
                        offsets + refs, out, stream_);
      record(kFilled);
    }
    info.cells = static_cast<std::uint32_t>(scalars_[1] & 0xffffffffu);
    last_total_ = total;
    size_order(total, n);

    // Order by (a, b).
    if (options.sorted && total > 1) {
      info.allocations += sort_pairs_by_ab(options.pair_order, out, total, n, pair_keys_, pair_keys_alt_, temp_, stream_);
    }
    record(kOrdered);
    info.pairs = total;
    return total;
  }

  // The kept buffers, sized in one place for a frame's counts: objects (and
  // the upload of update()), references, pairs. reserve() sizes them from
  // an estimate before the first frame, the frames from their counts.
  void size_uploads(std::uint32_t n) { reserve(boxes_, std::size_t{6} * n * sizeof(float)); }
  void size_objects(std::uint32_t n) {
    reserve(packed_, std::size_t{6} * n * sizeof(float));
    reserve(is_large_, (std::size_t{n} + 1) * 4);
    for (DeviceBuffer* d : {&ref_count_, &ref_offset_}) reserve(*d, (std::size_t{n} + 1) * 8);
  }
  void size_references(std::uint32_t refs, std::uint32_t large, std::uint32_t max_cells, std::uint64_t slots) {
    for (DeviceBuffer* d : {&keys_, &keys_alt_, &ids_, &ids_alt_}) reserve(*d, (std::size_t{refs} + 1) * 4);
    reserve(large_list_, (std::size_t{large} + 1) * 4);
    reserve(lanes_, std::size_t{6} * (refs + 1) * sizeof(float));
    reserve(cells_, 4);
    if (appending()) {
      reserve(total_, 8);
      return;
    }
    for (DeviceBuffer* d : {&counts_, &offsets_}) reserve(*d, (slots + 1) * 8);
    if (options.sweep == CellSweep::PerReference) {
      reserve(kept_, (std::size_t{refs} + 1) * sizeof(RowPairs));
      return;
    }
    // The block per cell's cell table.
    for (DeviceBuffer* d : {&positions_, &head_, &head_scan_}) reserve(*d, (std::size_t{refs} + 1) * 4);
    reserve(cell_begin_, (std::size_t{max_cells} + 2) * 4);
    for (DeviceBuffer* d : {&cell_ids_, &big_cells_}) reserve(*d, (std::size_t{max_cells} + 1) * 4);
    reserve(regions_, (std::size_t{max_cells} + 1) * sizeof(CellRegion));
  }
  void size_pairs(std::uint64_t total, std::uint32_t n) {
    reserve(pair_out_, (total + 1) * 8);
    last_total_ = total;
    size_order(total, n);
  }
  void size_order(std::uint64_t total, std::uint32_t n) {
    if (options.sorted) {
      const PairOrderBytes bytes = pair_order_bytes(options.pair_order, total, n);
      reserve(pair_keys_, bytes.keys);
      reserve(pair_keys_alt_, bytes.scratch);
    }
  }

  // PairWrite::Append (sorted, per reference: the constructor checks):
  // counted and written in one pass (launch_append_rows).
  bool appending() const { return options.pair_write == PairWrite::Append; }

  // The frame's pair total (at `total`, device) and cell count into
  // scalars_[0] and [1], waited for.
  void read_counts(const std::uint64_t* total) {
    check_cuda(cudaMemcpyAsync(scalars_, total, 8, cudaMemcpyDeviceToHost, stream_), "pair count");
    check_cuda(cudaMemcpyAsync(scalars_ + 1, cells_.as<std::uint32_t>(), 4, cudaMemcpyDeviceToHost, stream_), "cells");
    sync();
  }

  // out[0] = 0, out[1 + i] = in[0] + ... + in[i] (n + 1 entries).
  template <class T>
  void scan(const T* in, T* out, std::uint64_t n) {
    if (hbp::cuda::inclusive_sum(in, out, n, temp_, stream_)) ++info.allocations;
  }

  // The bounds pass's words, read back: the first defective box named
  // (InvalidInput), else the bounds, the extents into extents_, and both
  // remembered for the next frame's grid.
  Bounds take_bounds(const BoxLanesView& b, std::uint32_t n) {
    const std::uint32_t* words = reinterpret_cast<const std::uint32_t*>(pinned_);
    std::uint32_t acc[7];
    std::memcpy(acc, words, sizeof acc);
    std::memcpy(&extents_, words + kBoundsExtents, sizeof extents_);
    if (acc[6] < n) report_defect(b, acc[6]);
    Bounds bounds{{0, 0, 0}, {0, 0, 0}};
    if (n)
      for (int k = 0; k < 3; ++k) {
        bounds.lo[k] = from_ordered(acc[k]);
        bounds.hi[k] = from_ordered(acc[3 + k]);
      }
    grid_.remember(bounds, extents_, n);
    return bounds;
  }

  [[noreturn]] void report_defect(const BoxLanesView& b, std::uint32_t i) {
    float box[6];
    for (int l = 0; l < 6; ++l)
      check_cuda(cudaMemcpy(box + l, (l < 3 ? b.lo[l] : b.hi[l - 3]) + i, sizeof(float), cudaMemcpyDeviceToHost),
                 "defect read-back");
    const BoxLanesView one{{box, box + 1, box + 2}, {box + 3, box + 4, box + 5}};
    throw_box_defect(i, box_defect(one, 0));
  }

  void reserve(DeviceBuffer& buffer, std::size_t bytes) {
    if (buffer.reserve(bytes)) ++info.allocations;
  }
  void record(Stage s) { check_cuda(cudaEventRecord(events_[s], stream_), "cudaEventRecord"); }
  void sync() { check_cuda(cudaStreamSynchronize(stream_), "cudaStreamSynchronize"); }
  double between(Stage a, Stage b) {
    float ms = 0;
    check_cuda(cudaEventElapsedTime(&ms, events_[a], events_[b]), "cudaEventElapsedTime");
    return ms;
  }
  void times(bool transfers) {
    StageTimes& t = info.times;
    t.upload_ms = transfers ? between(kStart, kUploaded) : 0;
    t.bounds_ms = between(kUploaded, kBounds);
    t.refs_ms = between(kBounds, kRefs);
    t.sort_ms = between(kRefs, kSorted);
    t.count_ms = between(kSorted, kCounted);
    t.fill_ms = between(kCounted, kFilled);
    t.order_ms = between(kFilled, kOrdered);
    t.download_ms = transfers ? between(kOrdered, kDownloaded) : 0;
    t.frame_ms = between(kUploaded, kOrdered);
    std::size_t held = 0;
    for (const DeviceBuffer* d :
         {&boxes_, &packed_, &kept_, &acc_, &planes_, &ref_count_, &is_large_, &ref_offset_, &keys_,
          &keys_alt_, &ids_, &ids_alt_, &large_list_, &lanes_, &positions_, &head_, &head_scan_, &cell_begin_,
          &cell_ids_, &big_cells_, &regions_, &cells_, &total_, &counts_, &offsets_, &pair_out_, &pair_keys_, &pair_keys_alt_,
          &temp_})
      held += d->capacity();
    info.buffer_bytes = held;
  }

  int device_;  // the device current when the frame was made: its calls run there
  GridPlan grid_;
  ExtentHistogram extents_{};
  std::uint64_t last_total_ = 0;  // the last frame's pairs: the room a sorted frame starts with
  cudaStream_t own_stream_ = nullptr;
  cudaStream_t stream_ = nullptr;
  cudaEvent_t events_[kStages] = {};
  // Page-locked read-back room: the bounds words, then from kScalars the
  // per-frame counts (apart, so a count read back never lands on bounds
  // not yet taken).
  static constexpr std::size_t kScalars = (kBoundsWords + 1) / 2;
  std::uint64_t* pinned_ = nullptr;
  std::uint64_t* scalars_ = nullptr;
  DeviceBuffer boxes_, packed_, kept_, acc_, planes_, ref_count_, is_large_, ref_offset_, keys_,
      keys_alt_, ids_, ids_alt_, large_list_, lanes_, positions_, head_, head_scan_, cell_begin_, cell_ids_, big_cells_,
      regions_, cells_, total_, counts_, offsets_, pair_out_, pair_keys_, pair_keys_alt_, temp_;
};

}  // namespace

std::unique_ptr<FrameBroadPhase::Impl> make_device_frame(const FrameOptions& options) {
  return std::make_unique<DeviceFrame>(options);
}

}  // namespace hbp::cuda
