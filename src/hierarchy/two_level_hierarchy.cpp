// SPDX-License-Identifier: MIT
#include "hbp/two_level_hierarchy.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "hbp/error.hpp"
#include "hierarchy/cell_bvh.hpp"
#include "support/clock.hpp"

namespace hbp {

namespace {


struct CellTree {
  std::vector<BvhNode> nodes;
  std::vector<std::uint32_t> ids;  // entry index -> object id, as the leaves know them
  float built_cost = 0;            // SAH cost right after the last full build
  float cost = 0;                  // SAH cost now
};

enum class Outcome : std::uint8_t { Refit, Edit, Rebuild, Degraded };

struct RegionKey {
  float v[6];
  bool operator==(const RegionKey& o) const { return std::memcmp(v, o.v, sizeof v) == 0; }
};
struct RegionHash {
  std::size_t operator()(const RegionKey& k) const {
    std::uint64_t h = 1469598103934665603ull;
    std::uint32_t bits[6];
    std::memcpy(bits, k.v, sizeof bits);
    for (std::uint32_t b : bits) h = (h ^ b) * 1099511628211ull;
    return static_cast<std::size_t>(h);
  }
};
RegionKey key_of(const CellRegion& r) { return {{r.lo[0], r.lo[1], r.lo[2], r.hi[0], r.hi[1], r.hi[2]}}; }

bool ids_equal(std::span<const CellEntry> entries, const std::vector<std::uint32_t>& ids) {
  if (entries.size() != ids.size()) return false;
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (entries[i].id != ids[i]) return false;
  return true;
}

// Rebuilds the k-d tree of the partition from its cells' regions: the regions
// tile space as the leaves of a k-d tree, so some axis-aligned plane separates
// any set of two or more of them that came from one subtree. The plane nearest
// the middle (by count) is chosen. Workaround until KdPartition exposes its
// nodes: the planes found are the partition's own, possibly in another order.
class TopLevelBuilder {
 public:
  TopLevelBuilder(const KdPartition& p, std::vector<KdNode>& out) : p_(p), out_(out) {}

  void build() {
    out_.clear();
    std::vector<std::uint32_t> cells(p_.cell_count());
    std::iota(cells.begin(), cells.end(), 0u);
    out_.push_back(KdNode{0, -1, 0, 0});
    if (cells.empty()) return;
    node(0, cells.data(), cells.size());
  }

 private:
  void node(std::uint32_t at, std::uint32_t* cells, std::size_t count) {
    if (count == 1) {
      out_[at] = KdNode{0, -1, 0, cells[0]};
      return;
    }
    int best_axis = -1;
    std::size_t best_mid = 0;
    for (int axis = 0; axis < 3; ++axis) {
      std::sort(cells, cells + count, [&](std::uint32_t a, std::uint32_t b) {
        return p_.region(a).lo[axis] < p_.region(b).lo[axis];
      });
      float reach = -std::numeric_limits<float>::infinity();  // max hi of the prefix
      for (std::size_t j = 1; j < count; ++j) {
        reach = std::max(reach, p_.region(cells[j - 1]).hi[axis]);
        if (reach <= p_.region(cells[j]).lo[axis] && p_.region(cells[j - 1]).lo[axis] < p_.region(cells[j]).lo[axis]) {
          const auto dist = [&](std::size_t m) { return m > count / 2 ? m - count / 2 : count / 2 - m; };
          if (best_axis < 0 || dist(j) < dist(best_mid)) {
            best_axis = axis;
            best_mid = j;
          }
        }
      }
    }
    if (best_axis < 0) throw std::logic_error("two-level hierarchy: cell regions do not form a k-d tree");
    std::sort(cells, cells + count, [&](std::uint32_t a, std::uint32_t b) {
      return p_.region(a).lo[best_axis] < p_.region(b).lo[best_axis];
    });
    const float split = p_.region(cells[best_mid]).lo[best_axis];
    const auto child = static_cast<std::uint32_t>(out_.size());
    out_[at] = KdNode{split, best_axis, child, 0};
    out_.push_back({});
    out_.push_back({});
    node(child, cells, best_mid);
    node(child + 1, cells + best_mid, count - best_mid);
  }

  const KdPartition& p_;
  std::vector<KdNode>& out_;
};

}  // namespace

struct TwoLevelHierarchy::CellTrees {
  std::vector<CellTree> trees, previous;
  std::vector<CellRegion> previous_regions;
  std::unordered_map<RegionKey, std::uint32_t, RegionHash> index;
  std::vector<Outcome> outcome;
  tbb::enumerable_thread_specific<bvh::Scratch> scratch;
};

TwoLevelHierarchy::TwoLevelHierarchy(const HierarchyOptions& options)
    : options_(options),
      partition_(options.cell_limit, options.x_split_weight),
      trees_(std::make_unique<CellTrees>()) {
  if (!(options.rebuild_ratio >= 1)) throw InvalidInput("two-level hierarchy: rebuild ratio must be >= 1");
}
TwoLevelHierarchy::~TwoLevelHierarchy() = default;
TwoLevelHierarchy::TwoLevelHierarchy(TwoLevelHierarchy&&) noexcept = default;
TwoLevelHierarchy& TwoLevelHierarchy::operator=(TwoLevelHierarchy&&) noexcept = default;

std::span<const BvhNode> TwoLevelHierarchy::cell_bvh(std::uint32_t c) const { return trees_->trees[c].nodes; }

float TwoLevelHierarchy::cell_sah_cost(std::uint32_t c) const { return trees_->trees[c].cost; }

void TwoLevelHierarchy::update(const BoxArray& boxes) {
  const auto t0 = SteadyClock::now();
  stats_ = {};
  partition_.update(boxes);
  stats_.partition_ms = ms_since(t0);

  const auto t1 = SteadyClock::now();
  // Scene bounds.
  struct B {
    float lo[3], hi[3];
  };
  const float inf = std::numeric_limits<float>::infinity();
  const B empty{{inf, inf, inf}, {-inf, -inf, -inf}};
  const B all = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, boxes.size(), 1 << 16), empty,
      [&](const tbb::blocked_range<std::size_t>& r, B acc) {
        for (int k = 0; k < 3; ++k) {
          const float* mn = boxes.min(k);
          const float* mx = boxes.max(k);
          for (std::size_t i = r.begin(); i != r.end(); ++i) {
            acc.lo[k] = std::min(acc.lo[k], mn[i]);
            acc.hi[k] = std::max(acc.hi[k], mx[i]);
          }
        }
        return acc;
      },
      [](B a, const B& b) {
        for (int k = 0; k < 3; ++k) {
          a.lo[k] = std::min(a.lo[k], b.lo[k]);
          a.hi[k] = std::max(a.hi[k], b.hi[k]);
        }
        return a;
      });
  for (int k = 0; k < 3; ++k) {
    bounds_.min[k] = all.lo[k];
    bounds_.max[k] = all.hi[k];
  }

  // Match this frame's cells with last frame's by region: a cell whose region
  // is unchanged keeps its BVH.
  CellTrees& t = *trees_;
  std::swap(t.trees, t.previous);
  t.index.clear();
  for (std::uint32_t c = 0; c < t.previous_regions.size(); ++c) t.index.emplace(key_of(t.previous_regions[c]), c);
  const std::uint32_t cells = partition_.cell_count();
  t.trees.clear();
  t.trees.resize(cells);
  t.outcome.assign(cells, Outcome::Refit);
  const float ratio = options_.rebuild_ratio;
  const float edit_fraction = options_.max_edit_fraction;
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, cells, 1), [&](const tbb::blocked_range<std::uint32_t>& r) {
    bvh::Scratch& scratch = t.scratch.local();
    for (std::uint32_t c = r.begin(); c != r.end(); ++c) {
      const std::span<const CellEntry> entries = partition_.cell(c);
      CellTree& tree = t.trees[c];
      const auto found = t.index.find(key_of(partition_.region(c)));
      Outcome outcome = Outcome::Rebuild;
      bool reordered = false;
      if (found != t.index.end()) {
        tree = std::move(t.previous[found->second]);
        if (ids_equal(entries, tree.ids)) {
          outcome = Outcome::Refit;
        } else if (bvh::edit(entries, tree.ids, tree.nodes, 0, scratch)) {
          // Same objects, min-x order changed (the partition delivers cells
          // in min-x order): only the leaves' entry indices move.
          outcome = Outcome::Refit;
          reordered = true;
        } else {
          const auto max_changes = static_cast<std::uint32_t>(edit_fraction * static_cast<float>(entries.size()));
          if (bvh::edit(entries, tree.ids, tree.nodes, max_changes, scratch)) outcome = Outcome::Edit;
        }
      }
      if (outcome != Outcome::Rebuild) {
        tree.cost = bvh::refit(entries, tree.nodes);
        if (tree.cost > ratio * tree.built_cost) outcome = Outcome::Degraded;
      }
      if (outcome == Outcome::Rebuild || outcome == Outcome::Degraded) {
        bvh::build(entries, tree.nodes, scratch);
        tree.cost = tree.built_cost = bvh::sah_cost(tree.nodes);
      }
      if (outcome != Outcome::Refit || reordered) {
        tree.ids.resize(entries.size());
        for (std::size_t i = 0; i < entries.size(); ++i) tree.ids[i] = entries[i].id;
      }
      t.outcome[c] = outcome;
    }
  });
  t.previous.clear();
  stats_.cells = cells;
  for (std::uint32_t c = 0; c < cells; ++c) {
    switch (t.outcome[c]) {
      case Outcome::Refit: ++stats_.refitted; break;
      case Outcome::Edit: ++stats_.edited; break;
      case Outcome::Rebuild: ++stats_.rebuilt; break;
      case Outcome::Degraded: ++stats_.rebuilt, ++stats_.degraded; break;
    }
    stats_.bvh_nodes += t.trees[c].nodes.size();
  }
  stats_.bvh_ms = ms_since(t1);

  const auto t2 = SteadyClock::now();
  update_top_level();
  stats_.top_ms = ms_since(t2);
  stats_.total_ms = ms_since(t0);
}

void TwoLevelHierarchy::update_top_level() {
  const std::uint32_t cells = partition_.cell_count();
  CellTrees& t = *trees_;
  bool same = t.previous_regions.size() == cells && !kd_nodes_.empty();
  for (std::uint32_t c = 0; same && c < cells; ++c)
    same = key_of(t.previous_regions[c]) == key_of(partition_.region(c));
  if (same) return;
  t.previous_regions.resize(cells);
  for (std::uint32_t c = 0; c < cells; ++c) t.previous_regions[c] = partition_.region(c);
  TopLevelBuilder(partition_, kd_nodes_).build();
  stats_.top_rebuilt = true;
}

}  // namespace hbp
