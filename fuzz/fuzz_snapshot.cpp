// SPDX-License-Identifier: MIT
// libFuzzer target: BroadPhase::restore on fuzzer-chosen bytes.
//
// Input: 1 mode byte, then the snapshot's bytes.
//   mode bit 0  0: sealed: when the bytes hold a header, its size and XXH64
//               checksum are rewritten before the restore, so the fuzzer
//               reaches the section parser and the field checks behind the
//               checksum; 1: the bytes as given
//   mode bit 1  restore into a broad phase holding a small world (else empty)
// A restore either throws InvalidInput with the object unchanged (its own
// snapshot byte for byte), or succeeds; then the restored world's next
// update must be the brute-force one (pairs of live objects, at least one
// moving, overlapping, layers colliding; created / removed against the
// stored pairs), and snapshot -> restore -> snapshot a fixed point.
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <iterator>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "support/xxh64.hpp"

namespace {

using hbp::Handle;
using hbp::Pair;
using Bytes = std::vector<std::byte>;

void small_world(hbp::BroadPhase& bp) {
  std::vector<hbp::Aabb> boxes;
  for (int i = 0; i < 12; ++i)
    boxes.push_back({{float(i % 4), float(i / 4), 0}, {float(i % 4) + 1.5f, float(i / 4) + 1, 1}});
  const auto h = bp.add(boxes);
  bp.add(std::span<const hbp::Aabb>(boxes).first(3), {.is_static = true, .layer = 1});
  bp.update();
  bp.remove(std::vector<Handle>{h[2]});
  bp.set_static(std::vector<Handle>{h[5]}, true);
}

std::vector<Pair> minus(const std::vector<Pair>& a, const std::vector<Pair>& b) {
  std::vector<Pair> out;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

// The restored world's next update against brute force.
void check_update(hbp::BroadPhase& bp) {
  using hbp::fuzz::require;
  const std::vector<Pair> before = bp.last_update().pairs;
  // The live handles: a query over the whole float range returns them all.
  const float big = std::numeric_limits<float>::max();
  const std::vector<Handle> live = bp.query_box({{-big, -big, -big}, {big, big, big}});
  require(live.size() == bp.size(), "a query over everything misses live objects");
  if (live.size() > 2000) return;  // the brute force would take too long
  std::vector<Pair> want;
  for (std::size_t i = 0; i < live.size(); ++i)
    for (std::size_t j = i + 1; j < live.size(); ++j) {
      const Handle a = live[i], b = live[j];
      if (bp.is_static(a) && bp.is_static(b)) continue;
      if (!hbp::overlaps(bp.box(a), bp.box(b))) continue;
      if (!bp.collides(bp.layer(a), bp.layer(b))) continue;
      want.push_back({a, b});
    }
  const hbp::BroadPhaseUpdate& u = bp.update();
  require(u.pairs == want, "restored world's pairs differ from brute force");
  require(u.created == minus(want, before), "restored world's created pairs differ");
  require(u.removed == minus(before, want), "restored world's removed pairs differ");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using hbp::fuzz::finding;
  using hbp::fuzz::require;
  if (size < 1 || size > (1u << 20)) return 0;
  const std::uint8_t mode = data[0];
  Bytes bytes(reinterpret_cast<const std::byte*>(data + 1), reinterpret_cast<const std::byte*>(data + size));
  if (!(mode & 1) && bytes.size() >= 32) {
    const std::uint64_t n = bytes.size();
    std::memcpy(bytes.data() + 16, &n, 8);
    const std::uint64_t sum = hbp::detail::xxh64(bytes.data() + 32, bytes.size() - 32);
    std::memcpy(bytes.data() + 24, &sum, 8);
  }
  hbp::BroadPhase bp({.threads = 1});
  if (mode & 2) small_world(bp);
  const Bytes before = bp.snapshot();
  try {
    bp.restore(bytes);
  } catch (const hbp::InvalidInput& e) {
    require(std::string(e.what()).rfind("BroadPhase::restore: ", 0) == 0, std::string("unprefixed message: ") + e.what());
    require(bp.snapshot() == before, "a rejected restore changed the object");
    return 0;
  } catch (const std::exception& e) {
    finding(std::string("restore threw something other than InvalidInput: ") + e.what());
  }
  try {
    const Bytes once = bp.snapshot();
    hbp::BroadPhase again = hbp::BroadPhase::from_snapshot(once, {.threads = 2});
    require(again.snapshot() == once, "snapshot -> restore -> snapshot is not a fixed point");
    check_update(bp);
  } catch (const std::exception& e) {
    finding(std::string("an accepted snapshot failed later: ") + e.what());
  }
  return 0;
}
