#include "hbp/raytrace/colliding_objects.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>

#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/software_engine.hpp"

namespace hbp {

CollidingObjects colliding_objects(const TwoLevelHierarchy& h, const std::vector<Shape>& shapes) {
  const KdPartition& p = h.partition();
  struct Local {
    SoftwareEngine engine;
    BoxArray boxes;
    std::vector<Pair> local, pairs;
    std::vector<Contact> contacts;
    std::uint64_t candidates = 0;
  };
  tbb::enumerable_thread_specific<Local> locals;
  const NarrowPhase narrow({.contacts = false});
  tbb::parallel_for(std::uint32_t{0}, p.cell_count(), [&](std::uint32_t c) {
    Local& l = locals.local();
    const auto entries = p.cell(c);
    l.boxes.resize(entries.size());
    for (std::size_t i = 0; i < entries.size(); ++i)
      l.boxes.set(i, Aabb{{entries[i].min[0], entries[i].min[1], entries[i].min[2]},
                          {entries[i].max[0], entries[i].max[1], entries[i].max[2]}});
    l.local.clear();
    l.engine.find_pairs(l.boxes, l.local);
    l.pairs.clear();
    const CellRegion& region = p.region(c);
    for (const Pair& q : l.local) {
      const CellEntry& a = entries[q.a];
      const CellEntry& b = entries[q.b];
      if (region.contains(std::max(a.min[0], b.min[0]), std::max(a.min[1], b.min[1]), std::max(a.min[2], b.min[2])))
        l.pairs.push_back(make_pair(a.id, b.id));
    }
    l.candidates += l.pairs.size();
    narrow.process(shapes, l.pairs.data(), l.pairs.size(), l.contacts);
  });
  CollidingObjects out;
  out.flags.assign(shapes.size(), 0);
  for (const Local& l : locals) {
    out.candidate_pairs += l.candidates;
    out.colliding_pairs += l.contacts.size();
    for (const Contact& c : l.contacts) out.flags[c.a] = out.flags[c.b] = 1;
  }
  return out;
}

}  // namespace hbp
