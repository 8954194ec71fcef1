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

class SoftwareEngine final : public CellEngine {
 public:
  enum class Kernel { Sweep, AllPairs };
  // Measured on the paper scene (see docs/software-engine.md).
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

  // The instruction set the kernels run with ("avx512", "avx2", "scalar").
  static const char* isa();

  // The hybrid system's path, without intermediate copies. `cell` is sorted
  // by min x (the sweep needs it), ids[k] is the id reported for box k and
  // owner_codes[k] its owner code against `region` (owner_codes() below),
  // both readable up to cell.size() + kOutputSlack. Runs rows [row, n) and
  // writes hit k as the two ids (first[count + k], second[count + k]), not yet
  // ordered; returns the row it stopped at: n when done, earlier when fewer
  // than 2 (n - row) + kOutputSlack of `capacity` entries were free (drain
  // with write_pairs() and resume from there; a capacity of min_output(n)
  // always makes progress). The hits come in the same order however often
  // the caller drains.
  std::uint32_t emit_hits(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                          const CellRegion& region, std::uint32_t row, std::uint32_t* first, std::uint32_t* second,
                          std::size_t capacity, std::size_t& count) const;
  // Hits as canonical pairs (min id, max id), written to out[0 .. count).
  static void write_pairs(const std::uint32_t* first, const std::uint32_t* second, std::size_t count, Pair* out);
  // The hits rows [row, n) would emit, counted without storing them.
  std::uint64_t count_pairs(const BoxArray& cell, const std::uint32_t* ids, const std::uint32_t* owner_codes,
                            const CellRegion& region, std::uint32_t row) const;
  // Each box's owner code against `region` (the ownership rule split per
  // box, dedup/ownership.hpp: owner_code), padded: codes.size() becomes
  // cell.size() + kOutputSlack.
  static void owner_codes(const BoxArray& cell, const CellRegion& region, std::vector<std::uint32_t>& codes);
  static constexpr std::size_t min_output(std::uint32_t n) { return 2 * std::size_t{n} + 16; }
  // Spare entries emit_hits may write past the last hit it reports.
  static constexpr std::size_t kOutputSlack = 16;

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
