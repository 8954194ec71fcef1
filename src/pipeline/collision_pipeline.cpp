// SPDX-License-Identifier: MIT
#include "hbp/collision_pipeline.hpp"

#include <atomic>
#include <chrono>
#include <mutex>

#include "hbp/error.hpp"
#include "support/clock.hpp"

namespace hbp {

// The narrow phase takes the cells as they leave the engine, so the broad
// phase's list stays in cell order (sorting it would cost and serve nobody);
// every other option is the caller's.
CollisionPipeline::CollisionPipeline(const BroadPhaseOptions& broad, const NarrowOptions& narrow)
    : broad_(unsorted(broad)), narrow_(narrow) {}

BroadPhaseOptions CollisionPipeline::unsorted(BroadPhaseOptions options) {
  options.sorted = false;
  return options;
}

CollisionPipeline::~CollisionPipeline() = default;

const std::vector<Contact>& CollisionPipeline::update(const BoxArray& boxes, const std::vector<Shape>& shapes) {
  if (shapes.size() != boxes.size())
    throw InvalidInput("collision pipeline: " + std::to_string(boxes.size()) + " boxes but " +
                       std::to_string(shapes.size()) + " shapes");
  contacts_.clear();
  std::atomic<std::uint64_t> narrow_us{0};
  std::mutex grow;
  const auto t0 = SteadyClock::now();
  // Only the parallel consumer: each cell's narrow phase runs on whichever
  // worker finished its engine run, as many cells at once as there are
  // threads. An in-order sink would put the cells through a pipeline with a
  // few tokens, and one slow cell would then stall the others; the contacts
  // are put in cell order after the frame instead (a copy).
  broad_.update(boxes, {}, [&](std::uint32_t cell, const Pair* pairs, std::size_t count) {
    const double start = thread_cpu_ms();
    std::vector<Contact>* out;
    std::vector<NarrowCacheEntry>* learned;
    {
      // cell_contacts_ grows only when the partition has more cells than
      // ever before; the vectors themselves are reused frame to frame (a
      // deque keeps its elements in place when it grows).
      std::lock_guard lock(grow);
      if (cell_contacts_.size() <= cell) cell_contacts_.resize(cell + 1);
      if (cell_learned_.size() <= cell) cell_learned_.resize(cell + 1);
      out = &cell_contacts_[cell];
      learned = &cell_learned_[cell];
    }
    out->clear();
    learned->clear();
    narrow_.process(shapes, pairs, count, *out, &cache_, learned);
    narrow_us += static_cast<std::uint64_t>((thread_cpu_ms() - start) * 1e3);
  });
  const double broad_done_ms = ms_since(t0);
  const std::size_t cells = broad_.stats().cells;
  if (cell_contacts_.size() < cells) cell_contacts_.resize(cells);  // cells without pairs were never consumed
  if (cell_learned_.size() < cells) cell_learned_.resize(cells);
  for (std::size_t c = 0; c < cells; ++c)
    contacts_.insert(contacts_.end(), cell_contacts_[c].begin(), cell_contacts_[c].end());
  // What the frame learned replaces the cache (cells beyond this frame's
  // count are emptied so they add nothing).
  for (std::size_t c = cells; c < cell_learned_.size(); ++c) cell_learned_[c].clear();
  if (cell_learned_.size() > cells) cell_learned_.resize(cells);
  learned_lists_.clear();
  for (const auto& l : cell_learned_) learned_lists_.push_back(&l);
  cache_.commit(learned_lists_, shapes.size());
  stats_.wall_ms = ms_since(t0);
  stats_.tail_ms = stats_.wall_ms - broad_done_ms;
  stats_.candidates = broad_.stats().pairs;
  stats_.contacts = contacts_.size();
  stats_.narrow_cpu_ms = static_cast<double>(narrow_us.load()) * 1e-3;
  return contacts_;
}

}  // namespace hbp
