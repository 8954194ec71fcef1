// SPDX-License-Identifier: MIT
#pragma once
// The bodies of the LBVH peer's kernels (hbp::cuda::Lbvh), written once as
// host/device functions: lbvh_device.cu launches them as CUDA kernels,
// lbvh.cpp runs them on CPU threads. A pair is decided only by comparisons
// of the boxes' own coordinates (closed intervals) and of node bounds that
// are exact unions of them (min/max), so the pairs never depend on the
// Morton arithmetic, which shapes the tree only; that arithmetic is the
// same on both launchers anyway (no contraction, IEEE division), so they
// build the same tree and list the same pairs in the same order.
#include <cstdint>

#include "cuda/frame_bodies.hpp"
#include "hbp/host_device.hpp"

namespace hbp::cuda {

// A child reference with this bit set is a leaf (its sorted position);
// without it an internal node. Positions stay below 2^28 (kMaxFrameObjects).
inline constexpr std::uint32_t kLeafBit = 1u << 31;
inline constexpr std::uint32_t kNoParent = ~0u;
// Along any root-to-leaf path the keys' common prefix length grows strictly
// from one internal node to the next, and the keys are unique 64-bit values
// whose top two bits are 0 (a 30-bit Morton code over 32 bits), so a path
// has at most 62 internal nodes; the traversal's stack holds at most one
// pending sibling per internal node of its path.
inline constexpr int kLbvhStack = 64;

// The tree of one frame over n sorted leaves: internal node i (0 the root)
// has children left[i] and right[i], covers the leaf positions up to
// last[i], has parent node_parent[i] (kNoParent for the root) and bounds
// lo/hi (exact unions of its leaves' boxes); leaf_parent[q] is leaf q's.
struct LbvhNodes {
  std::uint32_t* left;
  std::uint32_t* right;
  std::uint32_t* last;
  std::uint32_t* node_parent;
  std::uint32_t* leaf_parent;
  float* lo[3];
  float* hi[3];
};

// The inverse of ordered_bits.
HBP_HOST_DEVICE inline float from_ordered_bits(std::uint32_t u) {
  const std::uint32_t bits = (u & 0x80000000u) ? (u & 0x7fffffffu) : ~u;
  float f;
  __builtin_memcpy(&f, &bits, sizeof f);
  return f;
}

// The low 10 bits of v spread to every third bit (bit b to bit 3b).
HBP_HOST_DEVICE inline std::uint32_t spread_bits(std::uint32_t v) {
  v &= 1023u;
  v = (v * 0x00010001u) & 0xFF0000FFu;
  v = (v * 0x00000101u) & 0x0F00F00Fu;
  v = (v * 0x00000011u) & 0xC30C30C3u;
  v = (v * 0x00000005u) & 0x49249249u;
  return v;
}

// The cell [0, 1023] of c within [lo, hi]. Halves throughout: with
// coordinates up to +-FLT_MAX, hi - lo and c - lo overflow, their halves do
// not. A flat axis gives 0 / 0 = NaN, which fails both comparisons and maps
// to 0, as does anything below; rounding past the top maps to 1023: no NaN
// or infinity reaches the integer conversion.
HBP_HOST_DEVICE inline std::uint32_t quantize(float c, float lo, float hi) {
  const float extent = 0.5f * hi - 0.5f * lo;
  const float offset = 0.5f * c - 0.5f * lo;
  const float q = offset / extent * 1024.0f;
  return q > 0.0f ? (q < 1023.0f ? static_cast<std::uint32_t>(q) : 1023u) : 0u;
}

// Box i's sort key: the Morton code (x, y, z interleaved, x highest) of its
// centre in the scene's bounds, given as ordered bits (min lo in bounds[0..2],
// max hi in bounds[3..5], launch_bounds' layout), over its index: unique
// keys, so the sort's order and the tree are total and deterministic (all
// boxes on one point are ordered by index).
HBP_HOST_DEVICE inline std::uint64_t morton_key(const std::uint32_t* bounds, const BoxLanesView& b, std::uint32_t i) {
  std::uint32_t code = 0;
  for (int k = 0; k < 3; ++k) {
    const float c = 0.5f * b.lo[k][i] + 0.5f * b.hi[k][i];
    code |= spread_bits(quantize(c, from_ordered_bits(bounds[k]), from_ordered_bits(bounds[3 + k]))) << (2 - k);
  }
  return (std::uint64_t{code} << 32) | i;
}

// Leading zeros of x != 0.
HBP_HOST_DEVICE inline int leading_zeros(std::uint64_t x) {
#if defined(__CUDA_ARCH__)
  return __clzll(static_cast<long long>(x));
#else
  return __builtin_clzll(x);
#endif
}

// Karras' delta: the common prefix length of sorted keys i and j, -1 when j
// is outside [0, n). Keys are unique, so i != j never gives 64.
HBP_HOST_DEVICE inline int common_prefix(const std::uint64_t* keys, std::uint32_t n, std::int64_t i, std::int64_t j) {
  if (j < 0 || j >= static_cast<std::int64_t>(n)) return -1;
  return leading_zeros(keys[i] ^ keys[j]);
}

// Internal node `node` of the radix tree over n >= 2 sorted unique keys
// (Karras 2012, "Maximizing parallelism in the construction of BVHs,
// octrees, and k-d trees", Figure 4): its leaf range, its split, its
// children, and the children's parent links. Each node writes only its own
// entries and its children's parents, so the nodes build in any order.
HBP_HOST_DEVICE inline void build_node(const std::uint64_t* keys, std::uint32_t n, std::uint32_t node,
                                       const LbvhNodes& t) {
  const std::int64_t i = node;
  // Direction of the range: towards the neighbour sharing the longer prefix
  // (never a tie for unique sorted keys).
  const std::int64_t d = common_prefix(keys, n, i, i + 1) > common_prefix(keys, n, i, i - 1) ? 1 : -1;
  const int delta_min = common_prefix(keys, n, i, i - d);
  std::int64_t l_max = 2;
  while (common_prefix(keys, n, i, i + l_max * d) > delta_min) l_max *= 2;
  std::int64_t l = 0;
  for (std::int64_t step = l_max / 2; step >= 1; step /= 2)
    if (common_prefix(keys, n, i, i + (l + step) * d) > delta_min) l += step;
  const std::int64_t j = i + l * d;
  // The split: the last position sharing more than the range's prefix with i.
  const int delta_node = common_prefix(keys, n, i, j);
  std::int64_t s = 0, step = l;
  do {
    step = (step + 1) / 2;
    if (common_prefix(keys, n, i, i + (s + step) * d) > delta_node) s += step;
  } while (step > 1);
  const std::int64_t split = i + s * d + (d < 0 ? -1 : 0);
  const std::int64_t first = i < j ? i : j, last = i < j ? j : i;
  const auto left = static_cast<std::uint32_t>(split), right = static_cast<std::uint32_t>(split + 1);
  if (split == first) {
    t.left[node] = left | kLeafBit;
    t.leaf_parent[left] = node;
  } else {
    t.left[node] = left;
    t.node_parent[left] = node;
  }
  if (split + 1 == last) {
    t.right[node] = right | kLeafBit;
    t.leaf_parent[right] = node;
  } else {
    t.right[node] = right;
    t.node_parent[right] = node;
  }
  t.last[node] = static_cast<std::uint32_t>(last);
  if (node == 0) t.node_parent[0] = kNoParent;
}

// Bounds bottom-up from leaf q: at each ancestor, arrive_second(node) says
// whether both children are now done (the first thread to arrive stops; the
// second computes the union and goes on up), so every internal node is
// computed once, after its children. The union is min/max, exact, so the
// bounds are the same whichever thread gets there second.
template <class ArriveSecond>
HBP_HOST_DEVICE inline void refit_from_leaf(const SortedLanes& leaves, const LbvhNodes& t, std::uint32_t q,
                                            ArriveSecond&& arrive_second) {
  for (std::uint32_t node = t.leaf_parent[q]; node != kNoParent && arrive_second(node); node = t.node_parent[node]) {
    const std::uint32_t l = t.left[node], r = t.right[node];
    for (int k = 0; k < 3; ++k) {
      const float l_lo = (l & kLeafBit) ? leaves.lo[k][l & ~kLeafBit] : t.lo[k][l];
      const float l_hi = (l & kLeafBit) ? leaves.hi[k][l & ~kLeafBit] : t.hi[k][l];
      const float r_lo = (r & kLeafBit) ? leaves.lo[k][r & ~kLeafBit] : t.lo[k][r];
      const float r_hi = (r & kLeafBit) ? leaves.hi[k][r & ~kLeafBit] : t.hi[k][r];
      t.lo[k][node] = l_lo < r_lo ? l_lo : r_lo;
      t.hi[k][node] = l_hi > r_hi ? l_hi : r_hi;
    }
  }
}

// The traversal of leaf p (a tree over n leaves): every leaf q > p whose box
// overlaps p's (closed intervals on all three axes), depth first, left
// before right. A subtree is skipped when its bounds miss p's box or when
// all its leaves lie at positions <= p (last <= p): the pair of p and such
// a leaf is found by the earlier leaf's traversal, so each pair is found
// once. emit(k, a, b) receives the k-th pair (object ids, not canonical).
// Returns the leaf's pair count.
template <class Emit>
HBP_HOST_DEVICE inline std::uint32_t lbvh_row(const SortedLanes& s, const LbvhNodes& t, std::uint32_t n,
                                              std::uint32_t p, Emit&& emit) {
  if (n < 2) return 0;
  const float x0 = s.lo[0][p], x1 = s.hi[0][p], y0 = s.lo[1][p], y1 = s.hi[1][p];
  const float z0 = s.lo[2][p], z1 = s.hi[2][p];
  std::uint32_t stack[kLbvhStack];
  int top = 0;
  std::uint32_t count = 0;
  std::uint32_t node = 0;
  for (;;) {
    std::uint32_t next = kNoParent;
    const std::uint32_t children[2] = {t.left[node], t.right[node]};
    for (const std::uint32_t c : children) {
      if (c & kLeafBit) {
        const std::uint32_t q = c & ~kLeafBit;
        if (q <= p) continue;
        const bool overlap = (x1 >= s.lo[0][q]) & (x0 <= s.hi[0][q]) & (y1 >= s.lo[1][q]) & (y0 <= s.hi[1][q]) &
                             (z1 >= s.lo[2][q]) & (z0 <= s.hi[2][q]);
        if (!overlap) continue;
        emit(count, s.id[p], s.id[q]);
        ++count;
      } else {
        if (t.last[c] <= p) continue;
        const bool overlap = (x1 >= t.lo[0][c]) & (x0 <= t.hi[0][c]) & (y1 >= t.lo[1][c]) & (y0 <= t.hi[1][c]) &
                             (z1 >= t.lo[2][c]) & (z0 <= t.hi[2][c]);
        if (!overlap) continue;
        if (next == kNoParent)
          next = c;
        else
          stack[top++] = c;
      }
    }
    if (next == kNoParent) {
      if (top == 0) break;
      next = stack[--top];
    }
    node = next;
  }
  return count;
}

}  // namespace hbp::cuda
