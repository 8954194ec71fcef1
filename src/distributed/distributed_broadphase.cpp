// SPDX-License-Identifier: MIT
// The distributed broad phase, one frame:
//   validate -> (re)build rank domains -> migrate objects to their owners ->
//   refresh ghosts (deltas against what each neighbour already holds) ->
//   local HybridBroadPhase on owned + ghosts -> keep the pairs whose
//   ownership point max(min_a, min_b) lies in this rank's domain.
// docs/distributed.md has the proof that this reports every pair once.
#include "hbp/distributed_broadphase.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstring>
#include <numeric>
#include <string>

#include "dedup/ownership.hpp"
#include "geometry/centre.hpp"
#include "distributed/rank_domains.hpp"
#include "hbp/error.hpp"
#include "support/clock.hpp"
#include "support/retained.hpp"

namespace hbp {
namespace {


// Wire formats. Migration: (id, box). Ghost message to one neighbour, the
// difference against the list the neighbour holds from us (same order):
//   u32 prev, removed, changed, added
//   [removed > 0]            kept mask, 1 bit per previous entry
//   [0 < changed < kept]     changed mask, 1 bit per kept entry
//   changed boxes (24 bytes each), then added (id, box) in id order
constexpr std::size_t kBoxBytes = sizeof(Aabb);
constexpr std::size_t kRecordBytes = 4 + kBoxBytes;
constexpr std::size_t kHeaderBytes = 16;
static_assert(sizeof(Aabb) == 24, "boxes travel as six floats");

void put(std::vector<unsigned char>& buf, const void* p, std::size_t n) {
  const auto* b = static_cast<const unsigned char*>(p);
  buf.insert(buf.end(), b, b + n);
}
template <class T>
T get(const unsigned char*& at) {
  T v;
  std::memcpy(&v, at, sizeof v);
  at += sizeof v;
  return v;
}
void put_mask(std::vector<unsigned char>& buf, const std::vector<unsigned char>& bits) {
  const std::size_t at = buf.size();
  buf.resize(at + (bits.size() + 7) / 8, 0);
  for (std::size_t i = 0; i < bits.size(); ++i)
    if (bits[i]) buf[at + i / 8] |= static_cast<unsigned char>(1u << (i % 8));
}
bool bit(const unsigned char* mask, std::size_t i) { return (mask[i / 8] >> (i % 8)) & 1u; }
bool same_box(const Aabb& a, const Aabb& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Collective error: the lowest rank with an error broadcasts its message and
// kind, and every rank throws it, so no rank is left waiting in a collective.
enum class ErrorKind : int { Input = 0, Capacity = 1 };
void collective_check(MPI_Comm comm, int rank, const std::string& local_error, ErrorKind kind = ErrorKind::Input) {
  const int mine = local_error.empty() ? INT_MAX : rank;
  int first = INT_MAX;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == INT_MAX) return;
  std::string msg = rank == first ? local_error : std::string();
  int head[2] = {static_cast<int>(msg.size()), static_cast<int>(kind)};
  MPI_Bcast(head, 2, MPI_INT, first, comm);
  msg.resize(static_cast<std::size_t>(head[0]));
  MPI_Bcast(msg.data(), head[0], MPI_CHAR, first, comm);
  msg = "distributed broad phase: rank " + std::to_string(first) + ": " + msg;
  if (static_cast<ErrorKind>(head[1]) == ErrorKind::Capacity) throw CapacityExceeded(msg);
  throw InvalidInput(msg);
}

// Sends bytes[d] to every rank d; returns what each source sent in `in`
// (contiguous, offsets in `in_off`).
void exchange(MPI_Comm comm, int p, const std::vector<std::vector<unsigned char>>& out,
              std::vector<unsigned char>& in, std::vector<int>& in_off, std::vector<int>& in_cnt,
              std::vector<unsigned char>& flat, std::vector<int>& out_off, std::vector<int>& out_cnt) {
  out_cnt.assign(static_cast<std::size_t>(p), 0);
  out_off.assign(static_cast<std::size_t>(p), 0);
  std::size_t total = 0;
  for (int d = 0; d < p; ++d) {
    const std::size_t sz = out[static_cast<std::size_t>(d)].size();
    if (sz > static_cast<std::size_t>(INT_MAX) || total + sz > static_cast<std::size_t>(INT_MAX))
      throw CapacityExceeded("distributed broad phase: more than 2 GiB to send in one exchange");
    out_cnt[static_cast<std::size_t>(d)] = static_cast<int>(sz);
    out_off[static_cast<std::size_t>(d)] = static_cast<int>(total);
    total += sz;
  }
  flat.resize(total);
  for (int d = 0; d < p; ++d)
    if (!out[static_cast<std::size_t>(d)].empty())
      std::memcpy(flat.data() + out_off[static_cast<std::size_t>(d)], out[static_cast<std::size_t>(d)].data(),
                  out[static_cast<std::size_t>(d)].size());
  in_cnt.assign(static_cast<std::size_t>(p), 0);
  MPI_Alltoall(out_cnt.data(), 1, MPI_INT, in_cnt.data(), 1, MPI_INT, comm);
  in_off.assign(static_cast<std::size_t>(p), 0);
  std::size_t in_total = 0;
  for (int s = 0; s < p; ++s) {
    in_off[static_cast<std::size_t>(s)] = static_cast<int>(in_total);
    in_total += static_cast<std::size_t>(in_cnt[static_cast<std::size_t>(s)]);
  }
  if (in_total > static_cast<std::size_t>(INT_MAX))
    throw CapacityExceeded("distributed broad phase: more than 2 GiB to receive in one exchange");
  in.resize(in_total);
  MPI_Alltoallv(flat.data(), out_cnt.data(), out_off.data(), MPI_BYTE, in.data(), in_cnt.data(), in_off.data(),
                MPI_BYTE, comm);
}

// Objects as (global id, box), kept in id order.
struct Objects {
  std::vector<std::uint32_t> ids;
  std::vector<Aabb> boxes;
  void clear() {
    ids.clear();
    boxes.clear();
  }
};

}  // namespace

struct DistributedBroadPhase::Impl {
  MPI_Comm comm = MPI_COMM_NULL;
  DistributedOptions options;
  int rank = 0, size = 1;
  distributed::RankDomains domains;
  double balance_floor = 0;  // imbalance right after the last bisection
  HybridBroadPhase local;

  Objects owned;                      // after migration, id order
  BoxArray owned_soa;                 // owned.boxes as SoA, for callers
  std::vector<Objects> sent;          // per neighbour: ghosts it holds from us
  std::vector<Objects> held;          // per source: ghosts we hold from it
  std::vector<std::uint32_t> local_ids;  // owned + ghosts, id order
  BoxArray local_boxes;
  std::vector<Pair> result;
  RankFrameStats stats;

  // Scratch, reused across frames.
  std::vector<std::vector<unsigned char>> out;
  std::vector<unsigned char> in, flat;
  std::vector<int> in_off, in_cnt, out_off, out_cnt;
  std::vector<float> cx, cy, cz;
  std::vector<int> reach;
  Objects stay, arrived, scratch;
  std::vector<Objects> now;
  std::vector<std::uint32_t> order;
  std::vector<unsigned char> inside;  // per local object: bits of min >= lo (0-2), min < hi (3-5)

  Impl(MPI_Comm c, const DistributedOptions& o) : comm(c), options(o), local(with_sorted(o.local)) {
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    sent.resize(static_cast<std::size_t>(size));
    held.resize(static_cast<std::size_t>(size));
    out.resize(static_cast<std::size_t>(size));
    if (!(options.rebalance_threshold >= 0))
      throw InvalidInput("distributed broad phase: rebalance_threshold must be >= 0");
  }
  static BroadPhaseOptions with_sorted(BroadPhaseOptions o) {
    o.sorted = true;
    return o;
  }

  // Exchange buffers sized for a burst (the first frame migrates most
  // objects) are given back once frames are small again, so memory follows
  // the current frame, not the peak.
  void trim() {
    for (auto& o : out) retained::trim(o);
    retained::trim(in);
    retained::trim(flat);
    for (auto* v : {&stay.ids, &arrived.ids, &scratch.ids}) retained::trim(*v);
    for (auto* v : {&stay.boxes, &arrived.boxes, &scratch.boxes}) retained::trim(*v);
  }

  void reset() {
    owned.clear();
    for (auto& s : sent) s.clear();
    for (auto& h : held) h.clear();
    local_ids.clear();
    result.clear();
  }

  // Owned-count imbalance of the supplied objects under the current domains.
  double imbalance(std::size_t n) {
    std::vector<std::uint64_t> mine(static_cast<std::size_t>(size), 0), all(static_cast<std::size_t>(size));
    for (std::size_t i = 0; i < n; ++i) ++mine[static_cast<std::size_t>(domains.owner(cx[i], cy[i], cz[i]))];
    MPI_Allreduce(mine.data(), all.data(), size, MPI_UINT64_T, MPI_SUM, comm);
    const double total = static_cast<double>(std::accumulate(all.begin(), all.end(), std::uint64_t{0}));
    if (total == 0) return 0;
    const double mean = total / size;
    double worst = 0;
    for (std::uint64_t c : all) worst = std::max(worst, std::abs(static_cast<double>(c) - mean) / mean);
    return worst;
  }

  void decompose(std::size_t n) {
    if (domains.built() && imbalance(n) <= options.rebalance_threshold + balance_floor) return;
    domains.build(comm, cx.data(), cy.data(), cz.data(), n);
    balance_floor = imbalance(n);
    stats.rebalanced = 1;
  }

  // Sends every supplied object whose centre lies elsewhere to its owner;
  // `owned` becomes this rank's objects in id order.
  std::string migrate(const std::vector<std::uint32_t>& ids, const BoxArray& boxes) {
    for (auto& o : out) o.clear();
    stay.clear();
    bool stay_sorted = true;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const int d = domains.owner(cx[i], cy[i], cz[i]);
      const Aabb b = boxes.get(i);
      if (d == rank) {
        stay_sorted &= stay.ids.empty() || stay.ids.back() < ids[i];
        stay.ids.push_back(ids[i]);
        stay.boxes.push_back(b);
      } else {
        put(out[static_cast<std::size_t>(d)], &ids[i], 4);
        put(out[static_cast<std::size_t>(d)], &b, kBoxBytes);
        ++stats.migrated_out;
        stats.bytes_sent += kRecordBytes;
      }
    }
    exchange(comm, size, out, in, in_off, in_cnt, flat, out_off, out_cnt);
    arrived.clear();
    for (const unsigned char* at = in.data(); at < in.data() + in.size();) {
      arrived.ids.push_back(get<std::uint32_t>(at));
      arrived.boxes.push_back(get<Aabb>(at));
    }
    // Usually the supply is last frame's owned_ids() (ascending) and few
    // objects arrive: sort only the arrivals and merge.
    if (!stay_sorted) sort_by_id(stay);
    sort_by_id(arrived);
    owned.ids.resize(stay.ids.size() + arrived.ids.size());
    owned.boxes.resize(owned.ids.size());
    std::string error;
    std::size_t i = 0, j = 0;
    for (std::size_t q = 0; q < owned.ids.size(); ++q) {
      const bool from_stay = j == arrived.ids.size() || (i < stay.ids.size() && stay.ids[i] <= arrived.ids[j]);
      const Objects& src = from_stay ? stay : arrived;
      std::size_t& at = from_stay ? i : j;
      owned.ids[q] = src.ids[at];
      owned.boxes[q] = src.boxes[at++];
      if (q > 0 && owned.ids[q - 1] == owned.ids[q] && error.empty())
        error = "object id " + std::to_string(owned.ids[q]) + " supplied twice";
    }
    return error;
  }

  void sort_by_id(Objects& o) {
    order.resize(o.ids.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return o.ids[a] < o.ids[b]; });
    scratch.ids.resize(order.size());
    scratch.boxes.resize(order.size());
    for (std::size_t q = 0; q < order.size(); ++q) {
      scratch.ids[q] = o.ids[order[q]];
      scratch.boxes[q] = o.boxes[order[q]];
    }
    std::swap(o, scratch);
  }

  // Ghost refresh: for each neighbour, the difference between the owned
  // objects whose closed box reaches its closed domain now and what it holds.
  void refresh_ghosts() {
    for (auto& o : out) o.clear();
    now.resize(static_cast<std::size_t>(size));
    for (Objects& o : now) o.clear();
    for (std::size_t i = 0; i < owned.ids.size(); ++i) {
      reach.clear();
      domains.ranks_reaching(owned.boxes[i], reach);
      for (int d : reach) {
        if (d == rank) continue;
        now[static_cast<std::size_t>(d)].ids.push_back(owned.ids[i]);
        now[static_cast<std::size_t>(d)].boxes.push_back(owned.boxes[i]);
      }
    }
    std::vector<unsigned char> kept_mask, changed_mask;
    std::vector<std::uint32_t> changed_at, added_at;
    for (int d = 0; d < size; ++d) {
      const Objects& prev = sent[static_cast<std::size_t>(d)];
      const Objects& cur = now[static_cast<std::size_t>(d)];
      if (prev.ids.empty() && cur.ids.empty()) continue;
      // Merge the two id-ordered lists.
      kept_mask.assign(prev.ids.size(), 0);
      changed_mask.clear();
      changed_at.clear();
      added_at.clear();
      std::size_t i = 0, j = 0;
      while (i < prev.ids.size() || j < cur.ids.size()) {
        if (j == cur.ids.size() || (i < prev.ids.size() && prev.ids[i] < cur.ids[j])) {
          ++i;  // removed
        } else if (i == prev.ids.size() || cur.ids[j] < prev.ids[i]) {
          added_at.push_back(static_cast<std::uint32_t>(j++));
        } else {
          kept_mask[i] = 1;
          const bool changed = !same_box(prev.boxes[i], cur.boxes[j]);
          changed_mask.push_back(changed);
          if (changed) changed_at.push_back(static_cast<std::uint32_t>(j));
          ++i, ++j;
        }
      }
      const auto kept = static_cast<std::uint32_t>(changed_mask.size());
      const std::uint32_t header[4] = {static_cast<std::uint32_t>(prev.ids.size()),
                                       static_cast<std::uint32_t>(prev.ids.size()) - kept,
                                       static_cast<std::uint32_t>(changed_at.size()),
                                       static_cast<std::uint32_t>(added_at.size())};
      auto& buf = out[static_cast<std::size_t>(d)];
      put(buf, header, kHeaderBytes);
      if (header[1] > 0) put_mask(buf, kept_mask);
      if (header[2] > 0 && header[2] < kept) put_mask(buf, changed_mask);
      for (std::uint32_t at : changed_at) put(buf, &cur.boxes[at], kBoxBytes);
      for (std::uint32_t at : added_at) {
        put(buf, &cur.ids[at], 4);
        put(buf, &cur.boxes[at], kBoxBytes);
      }
      stats.ghosts_sent += changed_at.size() + added_at.size();
      stats.ghosts_added += added_at.size();
      stats.ghosts_removed += header[1];
      stats.bytes_sent += buf.size();
    }
    exchange(comm, size, out, in, in_off, in_cnt, flat, out_off, out_cnt);
    std::swap(sent, now);  // now: last frame's lists, reused next frame
    // Apply each source's difference to the list we hold from it.
    Objects next;
    for (int s = 0; s < size; ++s) {
      Objects& list = held[static_cast<std::size_t>(s)];
      const int count = in_cnt[static_cast<std::size_t>(s)];
      if (count == 0) continue;  // the source had nothing for us before or now
      const unsigned char* at = in.data() + in_off[static_cast<std::size_t>(s)];
      std::uint32_t header[4];
      std::memcpy(header, at, kHeaderBytes);
      at += kHeaderBytes;
      const std::uint32_t prev = header[0], removed = header[1], changed = header[2], added = header[3];
      const std::uint32_t kept = prev - removed;
      const unsigned char* kept_bits = nullptr;
      const unsigned char* changed_bits = nullptr;
      if (removed > 0) kept_bits = at, at += (prev + 7) / 8;
      if (changed > 0 && changed < kept) changed_bits = at, at += (kept + 7) / 8;
      next.clear();
      std::uint32_t k = 0;
      for (std::uint32_t i = 0; i < prev; ++i) {
        if (kept_bits && !bit(kept_bits, i)) continue;
        Aabb box = list.boxes[i];
        if (changed == kept || (changed_bits && bit(changed_bits, k))) box = get<Aabb>(at);
        next.ids.push_back(list.ids[i]);
        next.boxes.push_back(box);
        ++k;
      }
      // Added entries, in id order, merged into the kept ones.
      const std::size_t mid = next.ids.size();
      for (std::uint32_t a = 0; a < added; ++a) {
        next.ids.push_back(get<std::uint32_t>(at));
        next.boxes.push_back(get<Aabb>(at));
      }
      if (mid > 0 && added > 0) {
        std::vector<std::uint32_t> order(next.ids.size());
        std::iota(order.begin(), order.end(), 0u);
        std::inplace_merge(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(mid), order.end(),
                           [&](std::uint32_t a, std::uint32_t b) { return next.ids[a] < next.ids[b]; });
        list.ids.resize(order.size());
        list.boxes.resize(order.size());
        for (std::size_t q = 0; q < order.size(); ++q) {
          list.ids[q] = next.ids[order[q]];
          list.boxes[q] = next.boxes[order[q]];
        }
      } else {
        std::swap(list, next);
      }
    }
  }

  // Owned + ghosts in id order into local_ids / local_boxes.
  std::string assemble() {
    struct Ref {
      std::uint32_t id;
      const Aabb* box;
    };
    std::vector<Ref> ghosts;
    for (const Objects& h : held)
      for (std::size_t i = 0; i < h.ids.size(); ++i) ghosts.push_back({h.ids[i], &h.boxes[i]});
    std::sort(ghosts.begin(), ghosts.end(), [](const Ref& a, const Ref& b) { return a.id < b.id; });
    stats.ghosts = ghosts.size();
    const std::size_t n = owned.ids.size() + ghosts.size();
    local_ids.resize(n);
    local_boxes.resize(n);
    std::string error;
    std::size_t i = 0, j = 0;
    for (std::size_t q = 0; q < n; ++q) {
      const bool take_owned = j == ghosts.size() || (i < owned.ids.size() && owned.ids[i] <= ghosts[j].id);
      if (i < owned.ids.size() && j < ghosts.size() && owned.ids[i] == ghosts[j].id && error.empty())
        error = "object id " + std::to_string(owned.ids[i]) + " supplied twice (owned here and elsewhere)";
      if (take_owned) {
        local_ids[q] = owned.ids[i];
        local_boxes.set(q, owned.boxes[i++]);
      } else {
        local_ids[q] = ghosts[j].id;
        local_boxes.set(q, *ghosts[j++].box);
      }
    }
    return error;
  }

  // Local broad phase; keep the pairs whose ownership point is in our domain.
  void find_pairs() {
    auto t = SteadyClock::now();
    // The local limits (max_pairs) may trip on one rank only: make it collective.
    result.clear();
    std::string error;
    try {
      local.update(local_boxes);
    } catch (const CapacityExceeded& e) {
      error = e.what();
    }
    collective_check(comm, rank, error, ErrorKind::Capacity);
    const std::vector<Pair>& found = local.pairs();
    stats.local_ms = ms_since(t);
    t = SteadyClock::now();
    stats.local_pairs = found.size();
    // The ownership rule per object (dedup::sides): one byte per object
    // instead of six floats per pair end.
    const CellRegion mine = domains.region(rank);
    inside.resize(local_ids.size());
    const float* mx = local_boxes.min(0);
    const float* my = local_boxes.min(1);
    const float* mz = local_boxes.min(2);
    for (std::size_t i = 0; i < local_ids.size(); ++i) inside[i] = dedup::sides(mine, mx[i], my[i], mz[i]);
    result.clear();
    for (const Pair& p : found) {
      // Local indices are in id order, so the mapped pairs stay canonical and sorted.
      if (dedup::owns_sides(inside[p.a], inside[p.b])) result.push_back({local_ids[p.a], local_ids[p.b]});
    }
    stats.pairs = result.size();
    stats.filter_ms = ms_since(t);
  }

  void update(const std::vector<std::uint32_t>& ids, const BoxArray& boxes) {
    const auto start = SteadyClock::now();
    stats = RankFrameStats{};
    std::string error;
    if (ids.size() != boxes.size())
      error = std::to_string(ids.size()) + " ids for " + std::to_string(boxes.size()) + " boxes";
    const std::size_t n = std::min(ids.size(), boxes.size());
    for (std::size_t i = 0; i < n && error.empty(); ++i)
      if (const char* defect = box_defect(boxes.get(i)))
        error = "object id " + std::to_string(ids[i]) + ": " + defect;
    collective_check(comm, rank, error);
    cx.resize(n);
    cy.resize(n);
    cz.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      cx[i] = geometry::centre(boxes.min(0)[i], boxes.max(0)[i]);
      cy[i] = geometry::centre(boxes.min(1)[i], boxes.max(1)[i]);
      cz[i] = geometry::centre(boxes.min(2)[i], boxes.max(2)[i]);
    }
    auto t = SteadyClock::now();
    decompose(n);
    stats.decompose_ms = ms_since(t);
    try {
      t = SteadyClock::now();
      collective_check(comm, rank, migrate(ids, boxes));
      stats.owned = owned.ids.size();
      stats.migrate_ms = ms_since(t);
      t = SteadyClock::now();
      refresh_ghosts();
      collective_check(comm, rank, assemble());
      stats.ghost_ms = ms_since(t);
    } catch (...) {
      reset();  // every rank is here (collective error): start afresh next frame
      throw;
    }
    find_pairs();
    trim();
    owned_soa.resize(owned.ids.size());
    for (std::size_t i = 0; i < owned.ids.size(); ++i) owned_soa.set(i, owned.boxes[i]);
    stats.wall_ms = ms_since(start);
  }
};

DistributedBroadPhase::DistributedBroadPhase(MPI_Comm comm, const DistributedOptions& options)
    : impl_(std::make_unique<Impl>(comm, options)) {}
DistributedBroadPhase::~DistributedBroadPhase() = default;
DistributedBroadPhase::DistributedBroadPhase(DistributedBroadPhase&&) noexcept = default;
DistributedBroadPhase& DistributedBroadPhase::operator=(DistributedBroadPhase&&) noexcept = default;

const std::vector<Pair>& DistributedBroadPhase::update(const std::vector<std::uint32_t>& ids,
                                                       const BoxArray& boxes) {
  impl_->update(ids, boxes);
  return impl_->result;
}
const std::vector<Pair>& DistributedBroadPhase::pairs() const { return impl_->result; }
const std::vector<std::uint32_t>& DistributedBroadPhase::owned_ids() const { return impl_->owned.ids; }
const BoxArray& DistributedBroadPhase::owned_boxes() const { return impl_->owned_soa; }
const RankFrameStats& DistributedBroadPhase::stats() const { return impl_->stats; }
const FrameStats& DistributedBroadPhase::local_stats() const { return impl_->local.stats(); }
CellRegion DistributedBroadPhase::domain() const {
  return impl_->domains.built() ? impl_->domains.region(impl_->rank) : CellRegion::everything();
}
int DistributedBroadPhase::rank_of(float x, float y, float z) const {
  return impl_->domains.built() ? impl_->domains.owner(x, y, z) : 0;
}
int DistributedBroadPhase::rank() const { return impl_->rank; }
int DistributedBroadPhase::size() const { return impl_->size; }

std::vector<RankFrameStats> DistributedBroadPhase::gather_stats(int root) const {
  std::vector<RankFrameStats> all(impl_->rank == root ? static_cast<std::size_t>(impl_->size) : 0);
  MPI_Gather(&impl_->stats, sizeof(RankFrameStats), MPI_BYTE, all.data(), sizeof(RankFrameStats), MPI_BYTE, root,
             impl_->comm);
  return all;
}

std::vector<Pair> gather_pairs(MPI_Comm comm, const std::vector<Pair>& local, int root) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  static_assert(sizeof(Pair) == 8, "pairs travel as two uint32");
  if (local.size() > static_cast<std::size_t>(INT_MAX) / 2)
    throw CapacityExceeded("gather_pairs: more than 2^30 pairs on one rank");
  const int mine = static_cast<int>(local.size() * 2);
  std::vector<int> counts(static_cast<std::size_t>(size)), offsets(static_cast<std::size_t>(size));
  MPI_Gather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, root, comm);
  std::vector<Pair> all;
  if (rank == root) {
    std::size_t total = 0;
    for (int r = 0; r < size; ++r) {
      offsets[static_cast<std::size_t>(r)] = static_cast<int>(total);
      total += static_cast<std::size_t>(counts[static_cast<std::size_t>(r)]);
      if (total > static_cast<std::size_t>(INT_MAX)) throw CapacityExceeded("gather_pairs: more than 2^30 pairs");
    }
    all.resize(total / 2);
  }
  MPI_Gatherv(local.data(), mine, MPI_UINT32_T, all.data(), counts.data(), offsets.data(), MPI_UINT32_T, root, comm);
  if (rank == root) sort_pairs(all);
  return all;
}

}  // namespace hbp
