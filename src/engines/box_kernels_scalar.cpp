// SPDX-License-Identifier: MIT
#include "dedup/ownership.hpp"
#include "engines/box_kernel_rows.hpp"
#include "engines/box_kernels.hpp"

namespace hbp::kernels {

namespace {

// Where a row's hits go: stored (row id, candidate id), or only counted.
struct Store {
  std::uint32_t* first;
  std::uint32_t* second;
  std::size_t count;
  void emit(std::uint32_t id_i, std::uint32_t id_j) {
    first[count] = id_i;
    second[count] = id_j;
    ++count;
  }
};

struct Count {
  std::uint64_t count = 0;
  void emit(std::uint32_t, std::uint32_t) { ++count; }
};

// This ISA's rows, for KernelsOf (box_kernel_rows.hpp).
struct Rows {
  static const CellRegion& region(const CellRegion& r) { return r; }

  template <class Out>
  static void sweep_row(const KernelInput& in, const CellRegion& r, std::uint32_t i, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxy = in.max[1], *maxz = in.max[2];
    const float bx = in.max[0][i], ly = miny[i], hy = maxy[i], lz = minz[i], hz = maxz[i];
    // Sorted by min x: min_x[j] >= min_x[i] and max_x[j] >= min_x[j], so only
    // min_x[j] <= max_x[i] remains to test on x, and it ends the scan.
    for (std::uint32_t j = i + 1; j < in.n && minx[j] <= bx; ++j) {
      if (maxy[j] >= ly && miny[j] <= hy && maxz[j] >= lz && minz[j] <= hz &&
          dedup::owns_sorted_x(r, ly, lz, minx[j], miny[j], minz[j]))
        out.emit(in.ids[i], in.ids[j]);
    }
  }

  template <class Out>
  static void allpairs_row(const KernelInput& in, const CellRegion& r, std::uint32_t i, Out& out) {
    const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
    const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
    const float lx = minx[i], hx = maxx[i], ly = miny[i], hy = maxy[i], lz = minz[i], hz = maxz[i];
    for (std::uint32_t j = i + 1; j < in.n; ++j) {
      if (maxx[j] >= lx && minx[j] <= hx && maxy[j] >= ly && miny[j] <= hy && maxz[j] >= lz && minz[j] <= hz &&
          dedup::owns(r, minx[j], miny[j], minz[j], lx, ly, lz))
        out.emit(in.ids[i], in.ids[j]);
    }
  }
};

}  // namespace

constinit const KernelSet kScalarKernels = KernelsOf<Rows, Store, Count>::set(canonical_pairs_scalar);

void canonical_pairs_scalar(const std::uint32_t* first, const std::uint32_t* second, std::size_t count,
                            std::uint32_t* pairs) {
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t f = first[k], s = second[k];
    pairs[2 * k] = f < s ? f : s;
    pairs[2 * k + 1] = f < s ? s : f;
  }
}

}  // namespace hbp::kernels
