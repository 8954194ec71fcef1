// SPDX-License-Identifier: MIT
#pragma once
// The CPU cell engine: SIMD over the structure-of-arrays boxes (AVX-512, AVX2
// or scalar, chosen at run time). Two kernels:
//  - Sweep:    sort-and-sweep on min x inside the cell, testing y and z of
//              every candidate 16 (AVX-512) or 8 (AVX2) at a time. The default.
//  - AllPairs: every pair, six comparisons each: the software counterpart of
//              the area-efficient datapath (quadratic in the cell size).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hbp/cell_engine.hpp"

namespace hbp {

class SoftwareEngine final : public CellEngine, public CellHitStream {
 public:
  enum class Kernel { Sweep, AllPairs };
  // Measured on the paper scene (see docs/hybrid-system.md).
  static constexpr std::uint32_t kDefaultSweepCellLimit = 1024;
  static constexpr std::uint32_t kDefaultAllPairsCellLimit = 128;

  explicit SoftwareEngine(Kernel kernel = Kernel::Sweep);
  std::string name() const override;
  std::uint32_t capacity() const override { return 0xFFFFFFFFu; }
  std::uint32_t default_cell_limit() const override;
  float x_split_weight() const override { return kernel_ == Kernel::Sweep ? 0.5f : 1.0f; }
  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override;
  CellRun find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) override;
  std::unique_ptr<CellEngine> clone() const override;
  // The hybrid system's path, without intermediate copies (CellHitStream).
  const CellHitStream* hit_stream() const override { return this; }

  // The instruction set the kernels run with ("avx512", "avx2", "scalar").
  static const char* isa();

  void owner_codes(const BoxArray& cell, const CellRegion& region, std::vector<std::uint32_t>& codes) const override;
  std::uint32_t emit_hits(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                          const CellRegion& region, std::uint32_t row, std::uint32_t* first, std::uint32_t* second,
                          std::size_t capacity, std::size_t& count) const override;
  std::uint64_t count_pairs(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                            const CellRegion& region, std::uint32_t row) const override;

 private:
  void run(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out);

  Kernel kernel_;
  std::vector<std::uint32_t> first_, second_;  // kernel output, reused across cells
  std::size_t stage_capacity_ = 0;
  std::vector<std::uint32_t> local_ids_;  // 0, 1, 2, ...: local indices as ids
  std::vector<std::uint32_t> codes_;      // the cell's owner codes
  BoxArray sorted_;                    // find_pairs on unsorted input
  std::vector<std::uint32_t> order_;
  std::vector<std::uint64_t> order_scratch_;  // the radix sort's key words
};

// Scalar all-pairs with no SIMD and no partition shortcut: the oracle run as
// a cell engine (for cross-checking the pipeline itself).
class BruteForceEngine final : public CellEngine {
 public:
  std::string name() const override { return "brute"; }
  std::uint32_t capacity() const override { return 0xFFFFFFFFu; }
  std::uint32_t default_cell_limit() const override { return 1024; }
  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override;
  std::unique_ptr<CellEngine> clone() const override { return std::make_unique<BruteForceEngine>(); }
};

}  // namespace hbp
