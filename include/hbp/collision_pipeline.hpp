// SPDX-License-Identifier: MIT
#pragma once
// The whole system of the paper: hybrid broad phase, then the exact narrow
// phase on each cell's pairs as soon as that cell leaves the engine, so the
// narrow phase of cell k overlaps the broad phase of later cells.
//
//   hbp::CollisionPipeline cp({.engine = "sw", .threads = 2});
//   const auto& contacts = cp.update(boxes, scenario.shapes());
#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/narrow/contact.hpp"
#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/shape.hpp"

namespace hbp {

struct PipelineStats {
  std::uint64_t candidates = 0;  // broad-phase pairs
  std::uint64_t contacts = 0;    // narrow-phase hits
  double wall_ms = 0;            // the overlapped whole, measured
  double narrow_cpu_ms = 0;      // narrow phase, summed over the threads that ran it
  // The serial work after the last cell (contacts put in cell order, cache
  // commit): the frame is about narrow_cpu_ms / threads + the broad phase's
  // share + this; a larger wall time means a thread was missing or idle.
  double tail_ms = 0;
};

class CollisionPipeline {
 public:
  // `broad`: the hybrid system's options; `sorted` does not apply (the
  // broad phase's list stays in cell order, as the narrow phase takes it).
  explicit CollisionPipeline(const BroadPhaseOptions& broad = {}, const NarrowOptions& narrow = {});
  ~CollisionPipeline();

  // Contacts in cell order (deterministic for any thread count). shapes[i]
  // is the shape whose AABB is boxes[i].
  const std::vector<Contact>& update(const BoxArray& boxes, const std::vector<Shape>& shapes);
  // The broad phase's HybridBroadPhase::reserve: memory for frames of up to
  // `objects` objects, provisioned before the first one.
  void reserve(std::size_t objects) { broad_.reserve(objects); }
  const std::vector<Contact>& contacts() const { return contacts_; }
  const PipelineStats& stats() const { return stats_; }
  const HybridBroadPhase& broad_phase() const { return broad_; }

 private:
  static BroadPhaseOptions unsorted(BroadPhaseOptions options);

  HybridBroadPhase broad_;
  NarrowPhase narrow_;
  // A deque: growing it never moves the vectors other threads are filling.
  std::deque<std::vector<Contact>> cell_contacts_;
  // Frame-to-frame coherence: last frame's per-pair directions (read by every
  // consumer) and what each cell's consumer learns this frame.
  NarrowCache cache_;
  std::deque<std::vector<NarrowCacheEntry>> cell_learned_;
  std::vector<const std::vector<NarrowCacheEntry>*> learned_lists_;
  std::vector<Contact> contacts_;
  PipelineStats stats_;
};

}  // namespace hbp
