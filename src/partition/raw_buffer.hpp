// SPDX-License-Identifier: MIT
#pragma once
// A growable array of trivially copyable elements that is NOT zero-filled on
// growth (std::vector::resize value-initialises: 40 MB of needless writes per
// frame for the cell entries of a million objects), and that gives memory back
// when the frame's needs fall far below what it holds, so a one-frame peak is
// not kept forever. Large buffers ask for transparent huge pages: on the
// virtual machines we measure on, first touching a 4 KiB page costs ~14 us
// (40 MB of fresh cell entries: 140 ms; with 2 MiB pages: 4 ms), and random
// gathers miss the TLB less.
#include <sys/mman.h>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>

#include "support/huge_pages.hpp"
#include "support/retained.hpp"

namespace hbp {

template <class T>
class RawBuffer {
  static_assert(std::is_trivially_copyable_v<T>);

 public:

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  T* data() { return data_.get(); }
  const T* data() const { return data_.get(); }
  T& operator[](std::size_t i) { return data_.get()[i]; }
  const T& operator[](std::size_t i) const { return data_.get()[i]; }

  // New size; the first min(old, new) elements are kept, the rest are
  // uninitialised. The capacity follows the retained rule (support/retained.hpp).
  void resize(std::size_t n) {
    if (n > capacity_ || retained::oversized(capacity_, n, retained::kSlack<T>)) reallocate(n + n / 8, std::min(size_, n));
    size_ = n;
  }
  // New size without ever shrinking the allocation (a scratch stack that
  // grows and shrinks many times within one frame).
  void grow(std::size_t n) {
    if (n > capacity_) reallocate(std::max(n, 2 * capacity_), size_);
    size_ = n;
  }
  // Capacity for n elements without touching them: untouched pages cost
  // nothing, and later resizes up to n neither move nor copy the contents.
  void reserve(std::size_t n) {
    if (n > capacity_) reallocate(n, size_);
  }
  void truncate(std::size_t n) { size_ = std::min(size_, n); }
  // Appends count elements (copied from src, which must not point into this buffer).
  void append(const T* src, std::size_t count) {
    if (count == 0) return;
    const std::size_t at = size_;
    if (at + count > capacity_) reallocate(2 * (at + count), at);
    std::memcpy(data_.get() + at, src, count * sizeof(T));
    size_ = at + count;
  }
  void clear() { size_ = 0; }
  void swap(RawBuffer& o) noexcept {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
  }

 private:
  // Large buffers are mapped straight from the kernel and unmapped when
  // freed: from malloc, glibc's dynamic mmap threshold would move them into
  // the heap after the first free, where a buffer that changes size each frame
  // fragments it and the resident set climbs frame after frame
  // (tests/test_memory_bound.cpp: 56 MB -> 250 MB over 300 frames).
  struct Free {
    std::size_t bytes = 0;  // mapped length; 0: from aligned_alloc
    void operator()(T* p) const {
      if (bytes)
        munmap(p, bytes);
      else
        std::free(p);
    }
  };

  void reallocate(std::size_t capacity, std::size_t keep) {
    // A mapped buffer that stays large is resized by the kernel (mremap moves
    // page tables, not bytes), so growth costs no copy and a buffer need not
    // reserve address space ahead of its contents.
    const std::size_t mapped = data_.get_deleter().bytes;
    if (mapped && capacity * sizeof(T) >= kHugePageBytes / 2) {
      const std::size_t bytes = whole_huge_pages(capacity * sizeof(T));
      void* p = mremap(data_.get(), mapped, bytes, MREMAP_MAYMOVE);
      if (p == MAP_FAILED) throw std::bad_alloc();
      madvise(p, bytes, MADV_HUGEPAGE);
      (void)data_.release();
      data_ = std::unique_ptr<T, Free>(static_cast<T*>(p), Free{bytes});
      capacity_ = bytes / sizeof(T);
      return;
    }
    std::unique_ptr<T, Free> next;
    if (capacity) {
      std::size_t bytes = capacity * sizeof(T);
      const bool huge = bytes >= kHugePageBytes / 2;
      if (huge) {
        bytes = whole_huge_pages(bytes);
        void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (p == MAP_FAILED) throw std::bad_alloc();
        madvise(p, bytes, MADV_HUGEPAGE);  // advice only: ignored where unsupported
        next = std::unique_ptr<T, Free>(static_cast<T*>(p), Free{bytes});
      } else {
        bytes = (bytes + 63) / 64 * 64;
        void* p = std::aligned_alloc(64, bytes);
        if (!p) throw std::bad_alloc();
        next.reset(static_cast<T*>(p));
      }
      capacity = bytes / sizeof(T);
    }
    if (keep) std::memcpy(next.get(), data_.get(), keep * sizeof(T));
    data_ = std::move(next);
    capacity_ = capacity;
  }

  std::unique_ptr<T, Free> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

}  // namespace hbp
