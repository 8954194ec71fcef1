// SPDX-License-Identifier: MIT
#include "hbp/raytrace/colliding_objects.hpp"

#include <tbb/enumerable_thread_specific.h>

#include "hbp/hybrid_broadphase.hpp"
#include "hbp/narrow/narrow_phase.hpp"

namespace hbp {

CollidingObjects colliding_objects(const TwoLevelHierarchy& h, const std::vector<Shape>& shapes) {
  // The broad phase proper on the hierarchy's own cells (engine, ownership
  // de-duplication: HybridBroadPhase's shared-partition frame); the narrow
  // phase runs on each cell's pairs on the worker that found them.
  HybridBroadPhase broad({.engine = "sw", .sorted = false});
  tbb::enumerable_thread_specific<std::vector<Contact>> contacts;
  const NarrowPhase narrow({.contacts = false});
  const std::vector<Pair>& pairs =
      broad.update(h.partition(), {}, [&](std::uint32_t, const Pair* cell_pairs, std::size_t count) {
        narrow.process(shapes, cell_pairs, count, contacts.local());
      });
  CollidingObjects out;
  out.flags.assign(shapes.size(), 0);
  out.candidate_pairs = pairs.size();
  for (const std::vector<Contact>& local : contacts) {
    out.colliding_pairs += local.size();
    for (const Contact& c : local) out.flags[c.a] = out.flags[c.b] = 1;
  }
  return out;
}

}  // namespace hbp
