// SPDX-License-Identifier: MIT
#pragma once
// The whole broad-phase frame as GPU kernels (docs/gpu.md): a sort-based
// uniform grid kept across frames, the accelerator's sweep (a thread per
// cell reference, or the paper's block per cell: CellSweep), the CPU's ownership rule for de-duplication, and a
// compacted pair list sized by counting (count, scan, fill), so no pair is
// ever dropped. The same kernel bodies run on the CPU (Launcher::Host, the
// "cuda-host" path tested against the brute-force oracle) or on a CUDA device
// (Launcher::Device).
//
// Pairs: canonical (a < b). With FrameOptions::sorted they are ordered by
// (a, b), the oracle's order; otherwise in the frame's own order (cell, lane,
// sweep; then the large boxes), which is the same on every launcher and
// thread count.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp::cuda {

enum class Launcher { Host, Device };

// How the device runs the accelerator's rows (the sweep of each reference
// against the later ones in its cell). Both give the same pairs in the same
// order; the host launcher runs each cell's rows on one CPU thread either way.
enum class CellSweep {
  // A thread per reference, reading its cell from the sorted lanes: no lane
  // idles on a small cell and a dense cell's rows spread over every SM.
  PerReference,
  // The paper's accelerator: a thread block per cell, the cell's boxes copied
  // into shared memory (the buffer memories), a lane per row; cells over
  // 256 boxes go to a fixed grid of larger blocks.
  BlockPerCell,
};

// The shape of the grid's cells (both launchers plan the same grid).
enum class CellShape {
  // Columns along the sweep axis x: y and z cut for a quarter of the
  // cubes' section (never finer than nearly every box is wide), x for a
  // quarter of their count. A row's candidates are the boxes of its cell's
  // y-z section that start within its x extent, so a narrower section means
  // fewer of them; an x cut only replicates boxes, the sweep stops on x by
  // itself.
  Columns,
  // Cubic cells: the same edge on every cut axis.
  Cubes,
};
// "columns", "cubes": the names the CLI, JSON and Python use. Parsing any
// other name throws InvalidInput "cell_shape: 'columns' or 'cubes', got ...".
const char* cell_shape_name(CellShape shape);
CellShape parse_cell_shape(const std::string& name);

// How the device orders a frame's pairs by (a, b) (FrameOptions::sorted).
// Both give the one sorted list; the host launcher sorts its own way.
enum class PairOrder {
  // One radix sort of the pairs as keys a << id_bits | b over the bits
  // the ids use (2 x 20 bits at a million objects: five passes).
  Radix,
  // Counting sort by a into per-object buckets (a histogram, a scan and a
  // scatter, each one pass over the pairs), then each bucket sorted by b
  // (CUB's segmented sort: a bucket holds one object's later partners).
  Buckets,
};

// How the device writes a frame's pairs (the host launcher always counts,
// scans and fills).
enum class PairWrite {
  // Every row counted, the counts scanned, the rows swept again writing at
  // their offsets: the frame's own order, the same on every launcher, run
  // and thread count.
  Offsets,
  // Sorted frames with CellSweep::PerReference only: each row counted and
  // written in one pass, a block taking its room with one atomic (the
  // rows run again in a larger buffer when the pairs outgrow the last
  // frame's room). The list's own order varies; the pair order makes it
  // the sorted one.
  Append,
};

struct FrameOptions {
  Launcher launcher = Launcher::Host;
  unsigned threads = 1;            // Host: CPU threads running the blocks (>= 1)
  bool sorted = true;              // pairs ordered by (a, b)
  std::uint64_t max_pairs = 0;     // 0: unlimited; else CapacityExceeded beyond
  std::uint32_t boxes_per_cell = 16;  // the cubes' target occupancy (>= 1); a column holds about 4x
  CellShape cell_shape = CellShape::Columns;  // the grid's cells
  CellSweep sweep = CellSweep::PerReference;  // Device: how the rows run
  PairOrder pair_order = PairOrder::Radix;    // Device, sorted: how the pairs are ordered
  PairWrite pair_write = PairWrite::Offsets;  // Device: how the pairs are written
};

// Boxes as six float lanes (min x/y/z, max x/y/z) of n objects: host memory
// for update(), device memory for update_device().
struct Lanes {
  const float* lo[3] = {nullptr, nullptr, nullptr};
  const float* hi[3] = {nullptr, nullptr, nullptr};
  std::uint32_t n = 0;
};

// A BoxArray's own lanes (no copy; valid while it is unchanged). Sizes past
// uint32 are the frame's to refuse (the object limit).
inline Lanes lanes_of(const BoxArray& boxes) {
  Lanes l;
  for (int k = 0; k < 3; ++k) {
    l.lo[k] = boxes.min(k);
    l.hi[k] = boxes.max(k);
  }
  l.n = boxes.size() > 0xffffffffu ? 0xffffffffu : static_cast<std::uint32_t>(boxes.size());
  return l;
}

// Boxes as the rows of an (n, 6) float32 array in device memory, as CuPy
// arrays and PyTorch tensors hold them: object i's min x, y, z, max x, y, z
// at data[i * row_stride + k * column_stride] (strides in floats; 6 and 1
// for a C-contiguous array).
struct DeviceRows {
  const float* data = nullptr;
  std::uint32_t n = 0;
  std::int64_t row_stride = 6;
  std::int64_t column_stride = 1;
};

// Most objects one frame takes: kMaxRefsPerBox (8) cell references each must
// fit the 32-bit reference index.
inline constexpr std::uint32_t kMaxFrameObjects = 1u << 28;

// InvalidInput unless `rows` can be a frame's device input: at most
// kMaxFrameObjects rows, data not null (for n > 0) and aligned to a float.
// update_device checks it first; a caller that must refuse an input before
// any device work (the Python module) calls it itself.
void check_device_rows(const DeviceRows& rows);

// Milliseconds per stage of the last frame. Device: CUDA events on the
// frame's stream (device time); upload/download are the host transfers,
// reported apart. Host: steady-clock wall time.
struct StageTimes {
  double upload_ms = 0;   // boxes host -> device (update()), or rows -> lanes on the device (DeviceRows)
  double bounds_ms = 0;   // bounds, validation
  double refs_ms = 0;     // count and emit cell references
  double sort_ms = 0;     // sort references by (cell, min x), gather, cells
  double count_ms = 0;    // per-lane pair counts, scan (PairWrite::Append: counted and written in one pass)
  double fill_ms = 0;     // pair list (PairWrite::Append: that pass again when the pairs outgrew its room)
  double order_ms = 0;    // sort pairs by (a, b) (FrameOptions::sorted)
  double download_ms = 0; // pairs device -> host (update() only)
  double frame_ms = 0;    // bounds .. order: the frame without transfers
};

struct FrameInfo {
  std::uint64_t pairs = 0;
  std::uint32_t references = 0;     // cell entries of the small boxes
  std::uint32_t cells = 0;          // non-empty cells
  std::uint32_t large = 0;          // boxes tested by the large pass
  std::uint32_t grid[3] = {0, 0, 0};
  bool replanned = false;           // the grid was planned anew this frame
  std::uint64_t allocations = 0;    // buffer (re)allocations this frame
  std::uint64_t buffer_bytes = 0;   // bytes held by the frame's buffers
  StageTimes times;
};

// Pairs left in device memory by update_device(): `count` canonical pairs
// (two uint32 each, a then b), valid until the next frame.
struct DevicePairs {
  const std::uint32_t* data = nullptr;
  std::uint64_t count = 0;
};

class FrameBroadPhase {
 public:
  // Launcher::Device throws hbp::Error "no CUDA device found" when none is.
  // Invalid options (threads or boxes_per_cell 0) throw InvalidInput.
  explicit FrameBroadPhase(const FrameOptions& options = {});
  ~FrameBroadPhase();
  FrameBroadPhase(FrameBroadPhase&&) noexcept;
  FrameBroadPhase& operator=(FrameBroadPhase&&) noexcept;

  // Host arrays in, host pairs out. Throws InvalidInput naming the first
  // object with a NaN/Inf coordinate or min > max, CapacityExceeded when the
  // frame has more than max_pairs pairs (found before any pair is written).
  const std::vector<Pair>& update(const Lanes& boxes);
  // Provisions the frame for `objects` objects before its first frame, so
  // that frame runs as a steady one does: the device launcher loads its
  // kernels (one frame over three boxes) and both launchers size their
  // buffers for the typical frame (about two cell references and two pairs
  // per object; a frame that needs more grows them then). Optional.
  void reserve(std::uint32_t objects);
  // Device entry (Launcher::Device only): lanes in device memory of the
  // frame's device (InvalidInput naming both devices otherwise), pairs left
  // in device memory; the work is queued on `stream` (a cudaStream_t of the
  // frame's device, InvalidInput otherwise; null: the default stream) and
  // finished when this returns.
  DevicePairs update_device(const Lanes& device_boxes, void* stream = nullptr);
  // The same for rows in device memory: transposed into the frame's own
  // lanes by a kernel on `stream` first (no host round trip).
  DevicePairs update_device(const DeviceRows& device_boxes, void* stream = nullptr);

  const std::vector<Pair>& pairs() const;
  const FrameInfo& info() const;
  const FrameOptions& options() const;

  // Implementation (one per launcher); public so the launchers' files can
  // derive from it.
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Whether a CUDA device is usable, and its name ("" when none).
bool device_available();
std::string device_name();

}  // namespace hbp::cuda
