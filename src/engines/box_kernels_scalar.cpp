#include "engines/box_kernels.hpp"

namespace hbp::kernels {

namespace {
inline float max_of(float a, float b) { return a > b ? a : b; }
}  // namespace

std::uint32_t sweep_scalar(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
  const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
  const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
  const CellRegion& r = in.region;
  for (std::uint32_t i = row; i < in.n; ++i) {
    if (out.capacity - out.count < std::size_t{in.n - i} + kOutputSlack) return i;
    const float bx = maxx[i], ly = miny[i], hy = maxy[i], lz = minz[i], hz = maxz[i];
    // Sorted by min x: min_x[j] >= min_x[i] and max_x[j] >= min_x[j], so only
    // min_x[j] <= max_x[i] remains to test on x, and it ends the scan.
    for (std::uint32_t j = i + 1; j < in.n && minx[j] <= bx; ++j) {
      if (maxy[j] >= ly && miny[j] <= hy && maxz[j] >= lz && minz[j] <= hz &&
          r.contains(minx[j], max_of(miny[j], ly), max_of(minz[j], lz))) {
        out.first[out.count] = i;
        out.second[out.count] = j;
        ++out.count;
      }
    }
  }
  return in.n;
}

std::uint32_t allpairs_scalar(const KernelInput& in, std::uint32_t row, KernelOutput& out) {
  const float *minx = in.min[0], *miny = in.min[1], *minz = in.min[2];
  const float *maxx = in.max[0], *maxy = in.max[1], *maxz = in.max[2];
  const CellRegion& r = in.region;
  for (std::uint32_t i = row; i < in.n; ++i) {
    if (out.capacity - out.count < std::size_t{in.n - i} + kOutputSlack) return i;
    const float lx = minx[i], hx = maxx[i], ly = miny[i], hy = maxy[i], lz = minz[i], hz = maxz[i];
    for (std::uint32_t j = i + 1; j < in.n; ++j) {
      if (maxx[j] >= lx && minx[j] <= hx && maxy[j] >= ly && miny[j] <= hy && maxz[j] >= lz && minz[j] <= hz &&
          r.contains(max_of(minx[j], lx), max_of(miny[j], ly), max_of(minz[j], lz))) {
        out.first[out.count] = i;
        out.second[out.count] = j;
        ++out.count;
      }
    }
  }
  return in.n;
}

}  // namespace hbp::kernels
