// SPDX-License-Identifier: MIT
#include "hbp/software_engine.hpp"

#include <algorithm>
#include <cstddef>
#include <numeric>

#include "dedup/owned_pairs.hpp"
#include "engines/box_kernels.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "support/radix_sort.hpp"
#include "support/retained.hpp"
#include <string>

namespace hbp {

SoftwareEngine::SoftwareEngine(Kernel kernel) : kernel_(kernel) {
  kernels::selected_isa();  // a bad HBP_SIMD fails here, when the engine is made, not in a worker
}

std::string SoftwareEngine::name() const { return kernel_ == Kernel::Sweep ? "sw" : "sw-allpairs"; }

std::uint32_t SoftwareEngine::default_cell_limit() const {
  return kernel_ == Kernel::Sweep ? kDefaultSweepCellLimit : kDefaultAllPairsCellLimit;
}

const char* SoftwareEngine::isa() { return kernels::isa_name(kernels::selected_isa()); }

std::unique_ptr<CellEngine> SoftwareEngine::clone() const { return std::make_unique<SoftwareEngine>(kernel_); }

static_assert(sizeof(Pair) == 2 * sizeof(std::uint32_t) && offsetof(Pair, a) == 0 && offsetof(Pair, b) == 4,
              "canonical_pairs writes Pairs as interleaved (a, b) words");
static_assert(SoftwareEngine::kOutputSlack == kernels::kOutputSlack);

static_assert(SoftwareEngine::min_output(100) == kernels::min_output(100));

namespace {

// The kernels' view of a cell of n >= 2 boxes: its coordinate columns, the
// objects' ids and owner codes, and the cell's region.
kernels::KernelInput kernel_input(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                                  std::uint32_t n, const CellRegion& region) {
  return {{cell.min(0), cell.min(1), cell.min(2)}, {cell.max(0), cell.max(1), cell.max(2)}, ids, owner_codes, n, region};
}

}  // namespace

void SoftwareEngine::owner_codes(const BoxArray& cell, const CellRegion& region, std::vector<std::uint32_t>& codes) const {
  const auto n = static_cast<std::uint32_t>(cell.size());
  // Sized for an over-full cell, released once cells are small again.
  retained::release(codes, std::size_t{n} + kOutputSlack);
  codes.resize(n + kOutputSlack);
  const float* const min[3] = {cell.min(0), cell.min(1), cell.min(2)};
  kernels::write_owner_codes(min, n, region, codes.data());
}

std::uint32_t SoftwareEngine::emit_hits(const BoxArray& cell, const std::uint32_t* ids,
                                        const std::uint32_t* owner_codes, const CellRegion& region, std::uint32_t row,
                                        std::uint32_t* first, std::uint32_t* second, std::size_t capacity,
                                        std::size_t& count) const {
  const auto n = static_cast<std::uint32_t>(cell.size());
  if (n < 2) return n;
  const kernels::KernelInput in = kernel_input(cell, ids, owner_codes, n, region);
  const kernels::Isa isa = kernels::selected_isa();
  const kernels::Kernel k = kernel_ == Kernel::Sweep ? kernels::sweep_kernel(isa) : kernels::allpairs_kernel(isa);
  kernels::KernelOutput o{first, second, capacity, count};
  row = k(in, row, o);
  count = o.count;
  return row;
}

void CellHitStream::write_pairs(const std::uint32_t* first, const std::uint32_t* second, std::size_t count,
                                 Pair* out) {
  if (count) kernels::canonical_pairs(kernels::selected_isa())(first, second, count, reinterpret_cast<std::uint32_t*>(out));
}

std::uint64_t SoftwareEngine::count_pairs(const BoxArray& cell, const std::uint32_t* ids,
                                          const std::uint32_t* owner_codes, const CellRegion& region,
                                          std::uint32_t row) const {
  const auto n = static_cast<std::uint32_t>(cell.size());
  if (n < 2) return 0;
  const kernels::KernelInput in = kernel_input(cell, ids, owner_codes, n, region);
  const kernels::Isa isa = kernels::selected_isa();
  return (kernel_ == Kernel::Sweep ? kernels::sweep_count_kernel(isa) : kernels::allpairs_count_kernel(isa))(in, row);
}

void SoftwareEngine::run(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) {
  const auto n = static_cast<std::uint32_t>(cell.size());
  if (n < 2) return;
  if (local_ids_.size() < n + kOutputSlack) {
    local_ids_.resize(n + kOutputSlack);
    std::iota(local_ids_.begin(), local_ids_.end(), 0u);
  }
  owner_codes(cell, region, codes_);
  // A stage of a few rows' worth, drained into `out` whenever it fills: the
  // engine's own memory stays bounded by the cell size, not its pair count.
  const std::size_t want = 4 * (std::size_t{n} + kOutputSlack);
  if (stage_capacity_ < want || stage_capacity_ > 4 * want) {
    stage_capacity_ = want;
    first_.assign(want, 0);
    second_.assign(want, 0);
  }
  // A call appends at most one stage past the pair limit before it stops.
  const std::size_t start = out.size();
  std::uint32_t row = 0;
  while (row < n) {
    // Near the pair limit a round gets only the room the limit leaves plus
    // two rows' worth, so the call stops within min_output(n) of it.
    const std::uint64_t appended = out.size() - start;
    const std::uint64_t left = appended < pair_limit_ ? pair_limit_ - appended : 0;
    const std::size_t room =
        left >= stage_capacity_ ? stage_capacity_ : std::min<std::size_t>(stage_capacity_, left + min_output(n));
    std::size_t count = 0;
    row = emit_hits(cell, local_ids_.data(), codes_.data(), region, row, first_.data(), second_.data(), room, count);
    const std::size_t base = out.size();
    out.resize(base + count);
    write_pairs(first_.data(), second_.data(), count, out.data() + base);
    if (out.size() - start > pair_limit_)
      throw CapacityExceeded("cell of " + std::to_string(n) + " boxes has more than " + std::to_string(pair_limit_) +
                             " overlapping pairs (max_pairs)");
  }
}

CellRun SoftwareEngine::find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) {
  run(cell, region, out);
  return {};
}

CellRun SoftwareEngine::find_pairs(const BoxArray& cell, std::vector<Pair>& out) {
  if (kernel_ == Kernel::AllPairs) {
    run(cell, CellRegion::everything(), out);
    return {};
  }
  // The sweep needs min-x order: sort a copy, map indices back.
  const auto n = static_cast<std::uint32_t>(cell.size());
  order_by_value(cell.min(0), n, order_, order_scratch_);  // ties by index, as a stable sort
  sorted_.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) sorted_.set(i, cell.get(order_[i]));
  const std::size_t base = out.size();
  run(sorted_, CellRegion::everything(), out);
  for (std::size_t p = base; p < out.size(); ++p) out[p] = make_pair(order_[out[p].a], order_[out[p].b]);
  return {};
}

CellRun BruteForceEngine::find_pairs(const BoxArray& cell, std::vector<Pair>& out) {
  // The oracle's loop, appending in place and counting against the pair
  // limit as it goes: a cell of coincident boxes stops at the limit instead
  // of building all n²/2 pairs first.
  append_brute_force_pairs(cell, out, pair_limit_);
  return {};
}

CellRun CellEngine::find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) {
  const std::size_t base = out.size();
  const CellRun run = find_pairs(cell, out);
  dedup::filter_owned(cell, region, out, base);
  return run;
}

void CellEngine::find_owned_pairs_batch(const CellBatch& batch, std::vector<Pair>& out,
                                        std::span<CellBatchOutcome> outcomes) {
  if (outcomes.size() != batch.cells() || batch.starts.size() != std::size_t{batch.cells()} + 1)
    throw InvalidInput("find_owned_pairs_batch: " + std::to_string(batch.cells()) + " cells, " +
                       std::to_string(batch.starts.size()) + " starts and " + std::to_string(outcomes.size()) +
                       " outcomes");
  const BoxArray& boxes = *batch.boxes;
  const std::size_t base = out.size();
  for (std::uint32_t k = 0; k < batch.cells(); ++k) {
    const std::uint32_t first = batch.starts[k], n = batch.starts[k + 1] - first;
    const bool whole = first == 0 && n == boxes.size();
    if (!whole) {
      batch_cell_.resize(n);
      for (int axis = 0; axis < 3; ++axis) {
        std::copy_n(boxes.min(axis) + first, n, batch_cell_.min(axis));
        std::copy_n(boxes.max(axis) + first, n, batch_cell_.max(axis));
      }
    }
    outcomes[k].run = find_owned_pairs(whole ? boxes : batch_cell_, batch.regions[k], out);
    outcomes[k].end = out.size();
    // Each call is bounded by the pair limit; so is the batch's list.
    if (out.size() - base > pair_limit_)
      throw CapacityExceeded("cell batch has more than the pair limit of " + std::to_string(pair_limit_) + " pairs");
  }
}

}  // namespace hbp
