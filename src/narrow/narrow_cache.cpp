// SPDX-License-Identifier: MIT
#include "hbp/narrow/narrow_cache.hpp"

#include <cstdint>
#include <string>

#include "hbp/error.hpp"
#include "support/huge_pages.hpp"
#include "support/retained.hpp"

namespace hbp {

void NarrowCache::commit(const std::vector<NarrowCacheEntry>* lists, std::size_t count, std::size_t objects) {
  commit_lists([lists](std::size_t l) -> const std::vector<NarrowCacheEntry>& { return lists[l]; }, count, objects);
}

void NarrowCache::commit(const std::vector<const std::vector<NarrowCacheEntry>*>& lists, std::size_t objects) {
  commit_lists([&lists](std::size_t l) -> const std::vector<NarrowCacheEntry>& { return *lists[l]; }, lists.size(),
               objects);
}

template <class List>
void NarrowCache::commit_lists(const List& list_at, std::size_t count, std::size_t objects) {
  // Every id checked before the cache changes: a refused commit leaves last
  // frame's entries in place.
  std::size_t total = 0;
  for (std::size_t l = 0; l < count; ++l) {
    for (const NarrowCacheEntry& e : list_at(l)) {
      if (e.pair.a >= objects || e.pair.b >= objects)
        throw InvalidInput("narrow cache: pair " + std::to_string(e.pair.a) + "-" + std::to_string(e.pair.b) +
                           " names an object beyond " + std::to_string(objects));
    }
    total += list_at(l).size();
  }
  // Buffers shrink with the frame: bounded by this frame's needs.
  retained::release(row_, objects + 1);
  retained::release(entries_, total);
  row_.assign(objects + 1, 0);
  for (std::size_t l = 0; l < count; ++l)
    for (const NarrowCacheEntry& e : list_at(l)) ++row_[e.pair.a + 1];
  for (std::size_t i = 0; i < objects; ++i) row_[i + 1] += row_[i];
  if (entries_.capacity() < total) {
    // Fresh storage (with an eighth to spare, so a slowly growing frame does
    // not reallocate every time), advised before resize() touches it: the
    // frame's lookups land all over the entries, and with 4 KiB pages nearly
    // every one would also walk the page table.
    entries_ = {};
    entries_.reserve(total + total / 8);
    advise_huge_pages(entries_.data(), entries_.capacity() * sizeof(NarrowCacheEntry));
  }
  entries_.resize(total);
  // Scatter by first object (row_[a] counts up to the row's end, then is
  // shifted back).
  for (std::size_t l = 0; l < count; ++l)
    for (const NarrowCacheEntry& e : list_at(l)) entries_[row_[e.pair.a]++] = e;
  for (std::size_t i = objects; i > 0; --i) row_[i] = row_[i - 1];
  row_[0] = 0;
}

void NarrowCache::clear() {
  row_.clear();
  entries_.clear();
}

}  // namespace hbp
