// SPDX-License-Identifier: MIT
#pragma once
// Inner loops of the software cell engine, one per instruction set. These
// translation units are compiled with different -m flags, so they use only
// intrinsics and plain C (no inline std templates, whose one-definition copies
// could be merged across ISAs by the linker; templates inside an anonymous
// namespace are fine: each file keeps its own copy).
#include <cstddef>
#include <cstdint>

#include "hbp/cell_region.hpp"

namespace hbp::kernels {

struct KernelInput {
  const float* min[3];
  const float* max[3];
  // ids[k]: the id reported for box k (the global object id, or k itself for
  // local indices); readable up to n + 16, like the box lanes.
  const std::uint32_t* ids;
  // owner_codes[k]: box k's owner code against `region` (write_owner_codes),
  // readable up to n + 16 like ids. The AVX-512 kernels test ownership on
  // these (one AND per row and vector), the others on the region.
  const std::uint32_t* owner_codes;
  std::uint32_t n;     // boxes; lanes are padded by >= 16 non-overlapping boxes
  CellRegion region;   // ownership filter (CellRegion::everything() for none)
};

// Writes dedup::owner_code(dedup::sides(...)) of boxes [0, n) against r to
// codes[0 .. n), and 16 padding codes that own nothing after them.
void write_owner_codes(const float* const min[3], std::uint32_t n, const CellRegion& r, std::uint32_t* codes);

struct KernelOutput {
  // Hit k is between the boxes with ids first[k] (the row) and second[k]:
  // not yet ordered. Emission stays light (the kernel scans many more
  // vectors than it finds pairs); canonical_pairs() orders and interleaves
  // the hits once, as they leave the stage.
  std::uint32_t* first;
  std::uint32_t* second;
  std::size_t capacity;   // entries in each array
  std::size_t count;      // hits written so far
};

// Both kernels process rows from `row` on and return the row they stopped at:
// n when done, earlier when the output might overflow. Rows i and i + 1 start
// only when 2 (n - i) + kOutputSlack entries are free (a row emits at most
// n - i - 1 pairs; vector kernels store whole vectors past the last pair;
// the AVX-512 sweep runs two rows at once, and where it stops must not
// depend on the room, or the order of the hits would); the caller drains or
// grows the buffer and resumes; an output of min_output(n) entries always
// makes progress.
inline constexpr std::size_t kOutputSlack = 16;
inline constexpr std::size_t min_output(std::uint32_t n) { return 2 * std::size_t{n} + kOutputSlack; }
//   sweep:     boxes sorted by min x; scans j > i while min_x[j] <= max_x[i]
//   all-pairs: any order; every j > i (the area-efficient datapath's work)
using Kernel = std::uint32_t (*)(const KernelInput& in, std::uint32_t row, KernelOutput& out);
// The same tests, counting the pairs of rows [row, n) without storing them
// (the hybrid system sizes its output before writing it).
using CountKernel = std::uint64_t (*)(const KernelInput& in, std::uint32_t row);
// Writes hit k as the canonical pair (min, max) of (first[k], second[k]) to
// pairs[2k], pairs[2k + 1] (the layout of hbp::Pair).
using CanonicalPairs = void (*)(const std::uint32_t* first, const std::uint32_t* second, std::size_t count,
                                std::uint32_t* pairs);

// One instruction set's kernels, each defined in box_kernels_<isa>.cpp
// (compiled for that ISA only).
struct KernelSet {
  Kernel sweep;
  Kernel allpairs;
  CountKernel sweep_count;
  CountKernel allpairs_count;
  CanonicalPairs canonical_pairs;
};
// The pair writers: AVX-512 has its own, the others share the scalar loop
// (it vectorises well enough without AVX-512's permutes).
void canonical_pairs_scalar(const std::uint32_t*, const std::uint32_t*, std::size_t, std::uint32_t*);
void canonical_pairs_avx512(const std::uint32_t*, const std::uint32_t*, std::size_t, std::uint32_t*);
extern const KernelSet kScalarKernels;
extern const KernelSet kAvx2Kernels;
extern const KernelSet kAvx512Kernels;

enum class Isa { Scalar, Avx2, Avx512 };
// Best ISA this CPU supports, unless HBP_SIMD=scalar|avx2|avx512 says otherwise
// (an ISA the CPU lacks falls back to the best it has). Any other value of
// HBP_SIMD throws InvalidInput listing the accepted ones (every call, until
// the variable is fixed: the choice is made once, on the first good call).
Isa selected_isa();
// The choice itself: `request` is HBP_SIMD's value (null or empty: unset).
Isa isa_for_request(const char* request, Isa best);
const char* isa_name(Isa isa);
const KernelSet& kernel_set(Isa isa);
// Its members one by one.
Kernel sweep_kernel(Isa isa);
Kernel allpairs_kernel(Isa isa);
CountKernel sweep_count_kernel(Isa isa);
CountKernel allpairs_count_kernel(Isa isa);
CanonicalPairs canonical_pairs(Isa isa);

}  // namespace hbp::kernels
