// SPDX-License-Identifier: MIT
#include "partition/kd_sampled_build.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <string>

#include "support/cpu_features.hpp"
#if HBP_X86_64_GNU
#include <immintrin.h>
#endif

#include "hbp/error.hpp"
#include "partition/kd_build.hpp"
#include "support/parallel_for.hpp"
#include "support/radix_sort.hpp"
#include "support/retained.hpp"

namespace hbp::kd {

namespace {

// One object in kTopSampleRate goes into the sample. A top-level node is
// split while it holds more than task_entries / kTopSampleRate samples, so
// every top-level decision rests on at least 1,024 samples at the default
// task size (its median within a few per cent of the exact one); the levels
// that shape the cells are built exactly, by the subtree tasks. (Sampling
// down to the cells lost: 20-60 samples a cell made cells of uneven size and
// shape, the sweep 11-21 % more instructions, and on clustered and huge
// scenes 25-80 % more cells: docs/hybrid-system.md.)
constexpr std::uint32_t kTopSampleRate = 32;
// The routing passes work on fixed chunks of ids, each counting its entries
// per task (a chunk x task table of at most kMaxCountWords words: larger
// chunks for frames of tens of millions of objects). The tasks' contents do
// not depend on the chunks (each task is sorted by min x, then id,
// afterwards).
constexpr std::uint32_t kRouteChunk = 1u << 14;
constexpr std::size_t kMaxCountWords = std::size_t{1} << 20;
// Objects stepped down the tree together (independent chains of loads: the
// latency of one level hides behind the others').
constexpr std::uint32_t kLockstep = 8;
constexpr std::uint32_t kAxisShift = 30;
constexpr std::uint32_t kChildMask = (1u << kAxisShift) - 1;
static_assert(kMaxNodes <= kChildMask + 1);
// task_of: the object reaches several tasks (its descent forked).
constexpr std::uint32_t kSeveralTasks = 0xFFFFFFFFu;
// In a chunk's list of the tasks of its objects in several: marks an
// object's last task.
constexpr std::uint32_t kLastTask = 0x80000000u;

// Calls visit(leaf node) for every leaf the box b (min x y z, max x y z)
// reaches, left to right, by the routing rule (left when min < split, right
// when max >= split). Returns the first node where the descent forked.
template <class Visit>
std::uint32_t descend(const KdTreeNode* nodes, const float* b, Visit&& visit) {
  // The stack holds at most one right child per level of the current path.
  std::array<std::uint32_t, KdPartition::kMaxDepth + 1> stack;
  std::uint32_t top = 0, fork = kNoHome, node = 0;
  while (true) {
    while (nodes[node].axis >= 0) {
      const KdTreeNode& nd = nodes[node];
      const bool left = b[nd.axis] < nd.split, right = b[3 + nd.axis] >= nd.split;
      if (left && right) {
        if (fork == kNoHome) fork = node;
        stack[top++] = nd.child + 1;
      }
      node = nd.child + (left ? 0u : 1u);
    }
    visit(node);
    if (top == 0) break;
    node = stack[--top];
  }
  return fork;
}

// One group of kLockstep objects from g (`lanes` of them; a short group
// repeats its first object) stepped down `depth` levels together, each level
// a load of its node, two compares and the next node: each one's node (a
// leaf) and whether its descent forked (it went on down its left side).
void route_group(const float* const src[6], std::uint32_t g, std::uint32_t lanes, const RouteNode* walk,
                 std::uint32_t depth, std::uint32_t* node, std::uint32_t* several) {
  float b[kLockstep][6];
  for (std::uint32_t l = 0; l < kLockstep; ++l) {
    const std::uint32_t i = l < lanes ? g + l : g;
    for (int a = 0; a < 6; ++a) b[l][a] = src[a][i];
    node[l] = 0;
    several[l] = 0;
  }
  for (std::uint32_t level = 0; level < depth; ++level) {
    for (std::uint32_t l = 0; l < kLockstep; ++l) {
      const RouteNode nd = walk[node[l]];
      const std::uint32_t axis = nd.child_axis >> kAxisShift;
      const bool left = b[l][axis] < nd.split;
      several[l] |= left & (b[l][3 + axis] >= nd.split);
      node[l] = (nd.child_axis & kChildMask) + !left;
    }
  }
}

// kRouteGroups groups of kLockstep objects from g stepped down `depth`
// levels: each one's node (a leaf) and whether its descent forked. The same
// steps as route_group, eight lanes at once (AVX2, chosen at run time: the
// library is built for plain x86-64): per level two gathers of the lanes'
// nodes, the box faces on each lane's axis by blends, two compares. The
// scalar group was the largest part of the routing pass (about a quarter of
// the warm build at 1,024,000 on two threads).
#if HBP_X86_64_GNU
static_assert(kLockstep == 8 && sizeof(RouteNode) == 8);
// kRouteGroups groups at once: a level's gathers wait ~20 cycles, and
// independent groups fill that wait (the count pass at 1,024,000, one
// thread: scalar ~24 ms; AVX2 one group ~24, two ~17, eight 10.8 ms).
constexpr std::uint32_t kRouteGroups = 8;
__attribute__((target("avx2"))) void route_groups_avx2(const float* const src[6], std::uint32_t g,
                                                       const RouteNode* walk, std::uint32_t depth,
                                                       std::uint32_t* node_out, std::uint32_t* several_out) {
  const auto* const words = reinterpret_cast<const int*>(walk);  // split, child_axis, split, ...
  const __m256i one = _mm256_set1_epi32(1), two = _mm256_set1_epi32(2);
  const __m256i child_mask = _mm256_set1_epi32(static_cast<int>(kChildMask));
  __m256 box[kRouteGroups][6];
  __m256i node[kRouteGroups], several[kRouteGroups];
  for (std::uint32_t q = 0; q < kRouteGroups; ++q) {
    for (int a = 0; a < 6; ++a) box[q][a] = _mm256_loadu_ps(src[a] + g + q * kLockstep);
    node[q] = several[q] = _mm256_setzero_si256();
  }
  for (std::uint32_t level = 0; level < depth; ++level) {
    for (std::uint32_t q = 0; q < kRouteGroups; ++q) {
      const __m256i at = _mm256_slli_epi32(node[q], 1);
      const __m256 split = _mm256_i32gather_ps(reinterpret_cast<const float*>(words), at, 4);
      const __m256i child_axis = _mm256_i32gather_epi32(words, _mm256_add_epi32(at, one), 4);
      const __m256i axis = _mm256_srli_epi32(child_axis, static_cast<int>(kAxisShift));
      const __m256 is1 = _mm256_castsi256_ps(_mm256_cmpeq_epi32(axis, one));
      const __m256 is2 = _mm256_castsi256_ps(_mm256_cmpeq_epi32(axis, two));
      const __m256 lo = _mm256_blendv_ps(_mm256_blendv_ps(box[q][0], box[q][1], is1), box[q][2], is2);
      const __m256 hi = _mm256_blendv_ps(_mm256_blendv_ps(box[q][3], box[q][4], is1), box[q][5], is2);
      const __m256i left = _mm256_castps_si256(_mm256_cmp_ps(lo, split, _CMP_LT_OQ));
      const __m256i right = _mm256_castps_si256(_mm256_cmp_ps(hi, split, _CMP_GE_OQ));
      several[q] = _mm256_or_si256(several[q], _mm256_and_si256(left, right));
      // child + !left: left is all ones (-1) where the box goes left.
      node[q] = _mm256_add_epi32(_mm256_add_epi32(_mm256_and_si256(child_axis, child_mask), one), left);
    }
  }
  for (std::uint32_t q = 0; q < kRouteGroups; ++q) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(node_out + q * kLockstep), node[q]);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(several_out + q * kLockstep), several[q]);
  }
}

constexpr std::uint32_t kRouteGroupsOr1 = kRouteGroups;
#else
constexpr std::uint32_t kRouteGroupsOr1 = 1;
#endif

// The sample: from each block of `rate` ids one object, at a pseudo-random
// position in the block (a fixed stride could alias with a pattern in the
// ids, e.g. every 32nd object a huge one).
std::uint32_t sample_id(std::uint32_t block, std::uint32_t rate) {
  std::uint32_t h = block * 0x9E3779B1u;
  h ^= h >> 15;
  h *= 0x85EBCA77u;
  h ^= h >> 13;
  return block * rate + h % rate;
}

}  // namespace

bool samples_top_levels(std::size_t n, std::uint32_t task_entries) { return n > task_entries; }

void build_top_levels(const BoxArray& boxes, const SplitRule& rule, std::uint32_t task_entries,
                      SampledTopBuffers& buffers, SubtreeBuilder& sample_tree, BuildScratch& sample_scratch,
                      std::vector<KdTreeNode>& nodes, RawBuffer<CellEntry>& out, RawBuffer<CellEntry>& scratch,
                      std::vector<BuildTask>& tasks) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const float* const src[6] = {boxes.min(0), boxes.min(1), boxes.min(2), boxes.max(0), boxes.max(1), boxes.max(2)};

  // 1. The planes: a tree over the sample, down to nodes of about a task.
  const std::uint32_t samples = n / kTopSampleRate;
  RawBuffer<CellEntry>& sample = buffers.sample;
  sample.resize(samples);
  for (std::uint32_t j = 0; j < samples; ++j) {
    const std::uint32_t id = sample_id(j, kTopSampleRate);
    sample[j] = {{src[0][id], src[1][id], src[2][id]}, {src[3][id], src[4][id], src[5][id]}, id, 0};
  }
  // Split down to the task size only, and never a node under the cell limit
  // (the exact build leaves such a node to its task, whose exact rule splits
  // it or not, the engine-cost rule included).
  const std::uint32_t top_limit = std::max(task_entries, rule.cell_limit) / kTopSampleRate;
  const SplitRule top_rule{std::max(2u, top_limit), rule.x_split_weight, nullptr};
  sample_tree.build(sample.data(), samples, 0, top_rule, true, sample_scratch);
  nodes = sample_tree.nodes;  // local indices: the root is node 0, as the partition's
  const KdTreeNode* const tree = nodes.data();

  // Tasks: the leaves, depth first, left before right.
  tasks.clear();
  std::uint32_t depth = 0;  // of the deepest leaf: the routing pass's steps
  {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> stack{{0, 0}};  // node, depth
    while (!stack.empty()) {
      const auto [x, d] = stack.back();
      stack.pop_back();
      if (nodes[x].axis < 0) {
        nodes[x].leaf = static_cast<std::uint32_t>(tasks.size());
        tasks.push_back({x, d, 0, 0});
        depth = std::max(depth, d);
      } else {
        stack.push_back({nodes[x].child + 1, d + 1});
        stack.push_back({nodes[x].child, d + 1});
      }
    }
  }
  const auto task_count = static_cast<std::uint32_t>(tasks.size());
  std::vector<RouteNode>& route = buffers.route;
  route.resize(nodes.size());
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const KdTreeNode& nd = nodes[k];
    route[k] = nd.axis < 0 ? RouteNode{std::numeric_limits<float>::infinity(), static_cast<std::uint32_t>(k)}
                           : RouteNode{nd.split, nd.child | static_cast<std::uint32_t>(nd.axis) << kAxisShift};
  }

  // 2. Count pass, in id order: every object's entries counted per (chunk,
  // task), its one task noted (or that it reaches several, then listed).
  std::uint32_t chunk = kRouteChunk;
  if (std::size_t{(n + chunk - 1) / chunk} * task_count > kMaxCountWords) {
    const std::size_t most = std::max<std::size_t>(1, kMaxCountWords / task_count);
    chunk = static_cast<std::uint32_t>((n + most - 1) / most);
  }
  const std::uint32_t chunks = (n + chunk - 1) / chunk;
  buffers.counts.resize(std::size_t{chunks} * task_count);
  // Each object's task lives in the start of `out` until the sort writes
  // there (memory the build touches anyway: a buffer of its own would be
  // fresh pages on a first frame).
  static_assert(sizeof(CellEntry) % sizeof(std::uint32_t) == 0);
  out.clear();
  out.grow((std::size_t{n} * sizeof(std::uint32_t) + sizeof(CellEntry) - 1) / sizeof(CellEntry));
  buffers.forked_tasks.resize(chunks);
  std::uint32_t* const counts = buffers.counts.data();
  auto* const task_of = reinterpret_cast<std::uint32_t*>(out.data());
  const RouteNode* const walk = route.data();
#if HBP_X86_64_GNU
  const bool avx2 = cpu_has_avx2();
#endif
  hbp::detail::parallel_for_each(chunks, [&, tree, walk, counts, task_of](std::size_t chunk_index) {
    const auto c = static_cast<std::uint32_t>(chunk_index);
    std::uint32_t* const count = counts + std::size_t{c} * task_count;
    std::fill(count, count + task_count, 0u);
    const std::uint32_t begin = c * chunk, end = std::min(n, (c + 1) * chunk);
    std::vector<std::uint32_t>& forked = buffers.forked.local();
    forked.clear();
    // Groups of kLockstep objects step down together (route_group); an
    // object whose descent forks is routed fully afterwards, one object at a
    // time.
    constexpr std::uint32_t kStep = kLockstep * kRouteGroupsOr1;
    for (std::uint32_t g = begin; g < end; g += kStep) {
      const std::uint32_t lanes = std::min(kStep, end - g);
      std::uint32_t node[kStep];
      std::uint32_t several[kStep];
#if HBP_X86_64_GNU
      if (lanes == kStep && avx2) {
        route_groups_avx2(src, g, walk, depth, node, several);
      } else
#endif
      {
        for (std::uint32_t q = 0; q < lanes; q += kLockstep)
          route_group(src, g + q, std::min(kLockstep, lanes - q), walk, depth, node + q, several + q);
      }
      for (std::uint32_t l = 0; l < lanes; ++l) {
        const std::uint32_t t = several[l] ? kSeveralTasks : tree[node[l]].leaf;
        task_of[g + l] = t;
        if (t != kSeveralTasks) ++count[t];
        else forked.push_back(g + l);
      }
    }
    std::vector<std::uint32_t>& listed = buffers.forked_tasks[c];
    listed.clear();
    for (const std::uint32_t i : forked) {
      const float b[6] = {src[0][i], src[1][i], src[2][i], src[3][i], src[4][i], src[5][i]};
      const std::uint32_t fork = descend(tree, b, [&](std::uint32_t leaf) {
        ++count[tree[leaf].leaf];
        listed.push_back(tree[leaf].leaf);
      });
      listed.back() |= kLastTask;
      listed.push_back(fork);  // the tag's fork: a global node
    }
  });

  // 3. Every task's place (tasks in order, within a task chunk after
  // chunk), and each chunk's cursor per task.
  std::size_t total = 0;
  for (std::uint32_t t = 0; t < task_count; ++t) {
    tasks[t].begin = total;
    for (std::uint32_t c = 0; c < chunks; ++c) {
      std::uint32_t& k = counts[std::size_t{c} * task_count + t];
      const std::uint32_t count = k;
      k = static_cast<std::uint32_t>(total);
      total += count;
    }
    if (total > std::numeric_limits<std::uint32_t>::max() / 2)
      throw CapacityExceeded("k-d partition: more than 2^31 cell entries (" + std::to_string(total) + ")");
    tasks[t].n = static_cast<std::uint32_t>(total - tasks[t].begin);
  }

  // 4. Scatter pass, in id order, into the scratch buffer: each object's
  // entry into its tasks. An object the top levels fork carries the fork in
  // its tag; its leftmost copy is its owner copy (the one that sets its home).
  scratch.clear();  // nothing kept: never copied if it must grow
  scratch.resize(total);
  CellEntry* const staged = scratch.data();
  hbp::detail::parallel_for_each(chunks, [&, counts, task_of, staged](std::size_t chunk_index) {
    const auto c = static_cast<std::uint32_t>(chunk_index);
    std::uint32_t* const cursor = counts + std::size_t{c} * task_count;
    const std::uint32_t* listed = buffers.forked_tasks[c].data();
    const std::uint32_t end = std::min(n, (c + 1) * chunk);
    for (std::uint32_t i = c * chunk; i < end; ++i) {
      CellEntry e = {{src[0][i], src[1][i], src[2][i]}, {src[3][i], src[4][i], src[5][i]}, i, kNoFork};
      const std::uint32_t t = task_of[i];
      if (t != kSeveralTasks) {
        staged[cursor[t]++] = e;
        continue;
      }
      const std::uint32_t* first = listed;
      while (!(*listed & kLastTask)) ++listed;
      const std::uint32_t fork = *++listed;
      ++listed;
      for (const std::uint32_t* w = first; w != listed - 1; ++w) {
        e.build_tag = fork | (w == first ? 0u : kNotOwner);
        staged[cursor[*w & ~kLastTask]++] = e;
      }
    }
  });
  for (auto& list : buffers.forked_tasks)
    retained::trim(list);

  // 5. Each task's entries (in id order) into `out` in min-x order, ties by
  // id, sorted in the cache. The sort keys and their scratch (16 bytes an
  // entry) live in the task's part of `out` (32 bytes an entry), written
  // back to front over them: per-thread key buffers were ~450 fresh 4 KiB
  // pages on the first frame.
  static_assert(sizeof(CellEntry) == 4 * sizeof(std::uint64_t));  // (RawBuffer memory is 64-byte aligned)
  out.clear();
  out.resize(total);
  CellEntry* const sorted = out.data();
  hbp::detail::parallel_for_each(task_count, [&, staged, sorted](std::size_t task_index) {
    const auto t = static_cast<std::uint32_t>(task_index);
    const BuildTask& task = tasks[t];
    const std::uint32_t m = task.n;
    if (m == 0) return;
    const CellEntry* e = staged + task.begin;
    CellEntry* to = sorted + task.begin;
    auto* const keys = reinterpret_cast<std::uint64_t*>(to);
    for (std::uint32_t i = 0; i < m; ++i) keys[i] = (std::uint64_t{float_order_key(e[i].min[0])} << 32) | i;
    const std::uint64_t* k = radix_sort_keyed_indices(keys, keys + m, m);
    // Entry i covers key words [4i, 4i + 4): written from the last entry
    // down, it only covers keys already read when they are in words [0, m).
    if (k != keys) std::memmove(keys, k, std::size_t{m} * sizeof(std::uint64_t));
    // (memcpy both ways: the words and the entries share memory.)
    for (std::uint32_t i = m; i-- > 0;) {
      std::uint64_t w;
      std::memcpy(&w, keys + i, sizeof w);
      std::memcpy(to + i, e + static_cast<std::uint32_t>(w), sizeof(CellEntry));
    }
  });
}

}  // namespace hbp::kd
