#include "hbp/software_engine.hpp"

#include <algorithm>
#include <numeric>

#include "engines/box_kernels.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
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

void SoftwareEngine::run(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) {
  const auto n = static_cast<std::uint32_t>(cell.size());
  if (n < 2) return;
  kernels::KernelInput in{{cell.min(0), cell.min(1), cell.min(2)}, {cell.max(0), cell.max(1), cell.max(2)}, n, region};
  const kernels::Isa isa = kernels::selected_isa();
  const kernels::Kernel k = kernel_ == Kernel::Sweep ? kernels::sweep_kernel(isa) : kernels::allpairs_kernel(isa);
  const std::size_t want = 2 * (std::size_t{n} + kernels::kOutputSlack);
  if (first_.size() < want) {
    first_.resize(want);
    second_.resize(want);
  }
  // The kernel writes at most `room` pairs per round: the buffer, but no
  // more than what the pair limit leaves plus one round's minimum (`want`),
  // so a call stops within `want` pairs of the limit.
  const std::size_t start = out.size();
  std::uint32_t row = 0;
  while (true) {
    const std::uint64_t appended = out.size() - start;
    const std::uint64_t left = appended < pair_limit_ ? pair_limit_ - appended : 0;
    const std::size_t room = left < first_.size() ? std::max<std::size_t>(want, left + want) : first_.size();
    kernels::KernelOutput o{first_.data(), second_.data(), std::min(room, first_.size()), 0};
    row = k(in, row, o);
    const std::size_t base = out.size();
    out.resize(base + o.count);
    for (std::size_t p = 0; p < o.count; ++p) out[base + p] = {first_[p], second_[p]};
    if (out.size() - start > pair_limit_)
      throw CapacityExceeded("cell of " + std::to_string(n) + " boxes has more than " + std::to_string(pair_limit_) +
                             " overlapping pairs (max_pairs)");
    if (row >= n) break;
    if (room == first_.size()) {  // a dense cell: grow and resume
      first_.resize(first_.size() * 2);
      second_.resize(second_.size() * 2);
    }
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
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0u);
  const float* minx = cell.min(0);
  std::stable_sort(order_.begin(), order_.end(), [&](std::uint32_t a, std::uint32_t b) { return minx[a] < minx[b]; });
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
  const auto n = static_cast<std::uint32_t>(cell.size());
  const std::size_t base = out.size();
  for (std::uint32_t i = 0; i + 1 < n; ++i) {
    const Aabb a = cell.get(i);
    for (std::uint32_t j = i + 1; j < n; ++j) {
      if (overlaps(a, cell.get(j))) out.push_back({i, j});
    }
    if (out.size() - base > pair_limit_)
      throw CapacityExceeded("cell of " + std::to_string(n) + " boxes has more than " + std::to_string(pair_limit_) +
                             " overlapping pairs (max_pairs)");
  }
  return {};
}

CellRun CellEngine::find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) {
  const std::size_t base = out.size();
  const CellRun run = find_pairs(cell, out);
  std::size_t keep = base;
  for (std::size_t p = base; p < out.size(); ++p) {
    const Pair q = out[p];
    const float x = std::max(cell.min(0)[q.a], cell.min(0)[q.b]);
    const float y = std::max(cell.min(1)[q.a], cell.min(1)[q.b]);
    const float z = std::max(cell.min(2)[q.a], cell.min(2)[q.b]);
    if (region.contains(x, y, z)) out[keep++] = q;
  }
  out.resize(keep);
  return run;
}

}  // namespace hbp
