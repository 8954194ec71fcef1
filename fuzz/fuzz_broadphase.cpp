// SPDX-License-Identifier: MIT
// libFuzzer target: the hybrid broad phase on fuzzer-chosen boxes, every
// frame checked against the oracle hbp::brute_force_pairs.
//
// Input: 3 header bytes, then boxes.
//   byte 0  engine: sw, sw-allpairs, brute, ae, mo, ae-sim, mo-sim, fuzz-tiny
//           (a brute-force engine holding 5 boxes, to drive the tiled path)
//   byte 1  cell limit: < 16 the engine's default, else 2 + byte % 62
//   byte 2  bits 0-1 coordinate scale: 1, 1/16, 2^-140 (denormals), 2^93
//           (near 1e30); bit 2 raw float32 boxes; bits 3-4 frames - 1;
//           bit 5 max_pairs = 1 + next byte; bit 6 unsorted output;
//           bit 7 mirror every other frame (objects teleport)
//   boxes   quantised: 6 bytes each, min = int8 * scale, extent = (byte >> 3)
//           * scale (0 for a zero-size axis); raw: 6 float32 (min xyz, max xyz)
// The boxes are split into frames of equal n and run through one
// HybridBroadPhase, so the partition is carried across frames.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#include "hbp/hybrid_broadphase.hpp"

namespace {

class TinyEngine final : public hbp::CellEngine {
 public:
  std::string name() const override { return "fuzz-tiny"; }
  std::uint32_t capacity() const override { return 5; }
  std::uint32_t default_cell_limit() const override { return 5; }
  hbp::CellRun find_pairs(const hbp::BoxArray& cell, std::vector<hbp::Pair>& out) override {
    if (cell.size() > capacity()) throw hbp::CapacityExceeded("fuzz-tiny holds 5 boxes");
    const auto p = hbp::brute_force_pairs(cell);
    out.insert(out.end(), p.begin(), p.end());
    return {};
  }
  std::unique_ptr<CellEngine> clone() const override { return std::make_unique<TinyEngine>(); }
};

const char* const kEngines[] = {"sw", "sw-allpairs", "brute", "ae", "mo", "ae-sim", "mo-sim", "fuzz-tiny"};

// Index of the first box a library must reject, or -1.
long first_invalid(const hbp::BoxArray& boxes) {
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (hbp::box_defect(boxes.get(i)) != nullptr) return static_cast<long>(i);
  return -1;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using hbp::fuzz::finding;
  using hbp::fuzz::require;
  static const bool registered = [] {
    hbp::hw::register_cell_engines();
    hbp::register_cell_engine("fuzz-tiny", [] { return std::unique_ptr<hbp::CellEngine>(new TinyEngine()); });
    return true;
  }();
  (void)registered;
  if (size < 3) return 0;
  const std::uint8_t e = data[0], l = data[1], mode = data[2];
  std::size_t at = 3;
  hbp::BroadPhaseOptions o;
  o.engine = kEngines[e % (sizeof kEngines / sizeof kEngines[0])];
  o.cell_limit = l < 16 ? 0 : 2 + l % 62;
  o.threads = 1;
  o.sorted = (mode & 0x40) == 0;
  if ((mode & 0x20) && at < size) o.max_pairs = 1 + std::uint64_t{data[at++]};
  const bool raw = (mode & 0x04) != 0;
  const unsigned frames = 1 + ((mode >> 3) & 3);
  const float scales[4] = {1.0f, 1.0f / 16, std::ldexp(1.0f, -140), std::ldexp(1.0f, 93)};
  const float scale = scales[mode & 3];

  const std::size_t box_bytes = raw ? 24 : 6;
  const std::size_t total = (size - at) / box_bytes;
  std::size_t n = total / frames;
  // The cycle-accurate simulators are slow: keep their cells small.
  if (o.engine == std::string("ae-sim") || o.engine == std::string("mo-sim")) n = std::min<std::size_t>(n, 96);

  std::unique_ptr<hbp::HybridBroadPhase> bp;
  try {
    bp = std::make_unique<hbp::HybridBroadPhase>(o);
  } catch (const hbp::Error& err) {
    finding(std::string("valid options refused: ") + err.what());
  }
  hbp::BoxArray boxes(n);
  for (unsigned f = 0; f < frames; ++f) {
    const bool mirror = (mode & 0x80) && (f % 2 == 1);
    for (std::size_t i = 0; i < n; ++i, at += box_bytes) {
      const std::uint8_t* b = data + at;
      hbp::Aabb box{};
      if (raw) {
        std::memcpy(&box.min, b, 12);
        std::memcpy(&box.max, b + 12, 12);
      } else {
        for (int k = 0; k < 3; ++k) {
          box.min[k] = static_cast<float>(static_cast<std::int8_t>(b[k])) * scale;
          box.max[k] = box.min[k] + static_cast<float>(b[3 + k] >> 3) * scale;
        }
      }
      if (mirror) {
        for (int k = 0; k < 3; ++k) {
          const float lo = -box.max[k], hi = -box.min[k];
          box.min[k] = lo;
          box.max[k] = hi;
        }
      }
      boxes.set(i, box);
    }
    const long bad = first_invalid(boxes);
    std::vector<hbp::Pair> got;
    try {
      got = bp->update(boxes);
    } catch (const hbp::InvalidInput& err) {
      require(bad >= 0, std::string("valid frame rejected: ") + err.what());
      require(std::string(err.what()).find("object " + std::to_string(bad) + ":") != std::string::npos,
              "rejection does not name object " + std::to_string(bad) + ": " + err.what());
      continue;  // the next frame must work on the same instance
    } catch (const hbp::CapacityExceeded& err) {
      require(o.max_pairs != 0, std::string("CapacityExceeded without max_pairs: ") + err.what());
      const auto want = hbp::brute_force_pairs(boxes);
      require(want.size() > o.max_pairs, "CapacityExceeded at " + std::to_string(want.size()) +
                                             " pairs with max_pairs " + std::to_string(o.max_pairs) + ": " +
                                             err.what());
      continue;
    }
    require(bad < 0, "invalid box " + std::to_string(bad) + " accepted");
    const auto want = hbp::brute_force_pairs(boxes);
    require(o.max_pairs == 0 || want.size() <= o.max_pairs, "more than max_pairs pairs returned");
    if (!o.sorted) hbp::sort_pairs(got);
    if (got != want) {
      std::vector<hbp::Pair> canon = got;
      const std::size_t dups = hbp::canonicalize(canon);
      finding(std::string("engine ") + o.engine + " limit " + std::to_string(bp->cell_limit()) + " frame " +
              std::to_string(f) + " n " + std::to_string(n) + ": " + std::to_string(dups) + " duplicates, " +
              hbp::diff_pairs(want, canon).summary());
    }
    require(bp->stats().pairs == want.size(), "stats().pairs != pair count");
  }
  return 0;
}
