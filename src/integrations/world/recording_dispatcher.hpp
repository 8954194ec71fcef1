// SPDX-License-Identifier: MIT
#pragma once
// A btCollisionDispatcher that records the pairs the broad phase hands to the
// narrow phase: at dispatchAllCollisionPairs(), each cache pair as the two
// bodies' user indices, kept when the proxies' exact AABBs overlap under the
// system's closed-interval rule, plus the raw count (the cache of a fattening
// broad phase holds more).
#include <cstddef>
#include <vector>

#include "hbp/pair.hpp"
#include "hbp/bullet/bullet_headers.hpp"

namespace hbp::bullet::world {

struct HandedPairs {
  std::size_t raw = 0;            // pairs in the cache
  std::vector<Pair> exact;        // (user index, user index), sorted canonical
  std::size_t duplicates = 0;     // exact pairs the cache held twice (a bug)
};

class RecordingDispatcher final : public btCollisionDispatcher {
 public:
  using btCollisionDispatcher::btCollisionDispatcher;
  void dispatchAllCollisionPairs(btOverlappingPairCache* cache, const btDispatcherInfo& info,
                                 btDispatcher* dispatcher) override;
  void set_recording(bool on) { recording_ = on; }
  const HandedPairs& last() const { return last_; }

 private:
  bool recording_ = false;
  HandedPairs last_;
};

}  // namespace hbp::bullet::world
