// SPDX-License-Identifier: MIT
#pragma once
// Drives a Verilated hbp_area_efficient / hbp_many_object through its
// streaming interface (rtl/README.md): reset, clear, load n boxes one per
// cycle, start, clock until done, collect the compare-stage pair lines cycle
// by cycle, optionally read the pair memory back and record a per-step
// address trace. One template serves every M/DEPTH build (each build is its
// own Verilated class with the same port names).
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/error.hpp"
#include "hbp/pair.hpp"
#include "verilated.h"

namespace hbp::rtl {

enum class Design { kAreaEfficient, kManyObject };

// One sequence step as seen on the sequencer's outputs.
struct RtlStep {
  std::uint64_t cycle = 0;               // cycle since start (first cycle after start = 1)
  std::vector<std::uint32_t> port_a;     // address on each group's port A
  std::vector<std::uint32_t> port_b;     // address on each group's port B
  std::vector<std::uint32_t> selector;   // many-object: lane j's multiplexer
};

struct RtlResult {
  std::vector<Pair> pairs;                // compare-stage lines, in order
  std::vector<std::uint64_t> pair_cycle;  // cycle (since start) each line appeared
  std::uint64_t cycles = 0;               // RTL counters; cycles = seq + restart + drain
  std::uint64_t cyc_load = 0, cyc_seq = 0, cyc_restart = 0, cyc_drain = 0;
  std::uint64_t cycles_to_done = 0;       // cycle (since start) in which done is first high
  std::vector<Pair> memory_pairs;         // read back from the pair memory
  std::uint32_t memory_count = 0;
  bool memory_overflow = false;
  std::vector<RtlStep> trace;
};

namespace detail {

// Bits [lo, lo+w) of a Verilated port (integral or VlWide), w <= 32.
template <class T>
std::uint32_t bits(const T& sig, unsigned lo, unsigned w) {
  std::uint64_t v = 0;
  if constexpr (std::is_integral_v<T>) {
    v = static_cast<std::uint64_t>(sig) >> lo;
  } else {
    const unsigned word = lo / 32, off = lo % 32;
    v = sig.at(word) >> off;
    if (off + w > 32 && (word + 1) * 32 < sizeof(sig) * 8)
      v |= static_cast<std::uint64_t>(sig.at(word + 1)) << (32 - off);
  }
  return static_cast<std::uint32_t>(v & ((w >= 32) ? 0xffffffffull : ((1ull << w) - 1)));
}

inline std::uint32_t float_bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

}  // namespace detail

template <class V>
class RtlDriver {
 public:
  RtlDriver(Design design, unsigned m, unsigned depth)
      : design_(design), m_(m), depth_(depth), ctx_(std::make_unique<VerilatedContext>()) {
    ctx_->fatalOnError(false);
    top_ = std::make_unique<V>(ctx_.get(), "top");
    lanes_ = design == Design::kAreaEfficient ? 2 * m - 1 : m;
    capacity_ = design == Design::kAreaEfficient ? depth : depth * m;
    pw_ = 1;
    while ((1u << pw_) < capacity_) ++pw_;
    aw_ = 1;
    while ((1u << aw_) < depth_) ++aw_;
    top_->clk = 0;
    top_->rst = 1;
    tick();
    top_->rst = 0;
  }
  ~RtlDriver() { top_->final(); }
  RtlDriver(const RtlDriver&) = delete;
  RtlDriver& operator=(const RtlDriver&) = delete;

  unsigned lanes() const { return lanes_; }
  std::uint32_t capacity() const { return capacity_; }

  // Runs all-pairs over `boxes`. `read_memory`: pop the pair memory after
  // done; `trace`: record every sequence step's port addresses.
  RtlResult run(const BoxArray& boxes, bool read_memory = false, bool trace = false) {
    if (boxes.size() > capacity_)
      throw std::length_error("rtl: " + std::to_string(boxes.size()) +
                              " boxes exceed the RTL capacity " + std::to_string(capacity_));
    RtlResult r;
    top_->clear = 1;
    tick();
    top_->clear = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const Aabb b = boxes.get(i);
      for (int c = 0; c < 3; ++c) {
        top_->load_box.at(c) = detail::float_bits(b.min[c]);
        top_->load_box.at(3 + c) = detail::float_bits(b.max[c]);
      }
      top_->load_valid = 1;
      tick();
    }
    top_->load_valid = 0;
    top_->start = 1;
    tick();
    top_->start = 0;
    const std::uint64_t n = boxes.size();
    const std::uint64_t limit = 64 + 16 * n * n;  // generous bound on steps + bubbles
    // Cycle 1 is the first cycle after the start edge (the first step).
    std::uint64_t now = 1;
    for (;;) {
      if (trace && top_->dbg_step) r.trace.push_back(step(now));
      if (top_->out_valid) collect(now, r);
      if (top_->done) break;
      if (now > limit) throw std::runtime_error("rtl: no done after " + std::to_string(now) + " cycles");
      tick();
      ++now;
    }
    r.cycles_to_done = now;
    r.cycles = top_->cycles;
    r.cyc_load = top_->cyc_load;
    r.cyc_seq = top_->cyc_seq;
    r.cyc_drain = top_->cyc_drain;
    r.cyc_restart = top_->cyc_restart;
    r.memory_count = top_->pair_count;
    r.memory_overflow = top_->pair_overflow;
    if (read_memory) {
      const std::uint64_t stored = std::min<std::uint64_t>(r.memory_count, stored_limit());
      for (std::uint64_t k = 0; k < stored; ++k) {
        top_->pair_pop = 1;
        tick();
        top_->pair_pop = 0;
        if (!top_->pair_rvalid) throw std::runtime_error("rtl: pair memory read not valid");
        const std::uint64_t d = top_->pair_rdata;
        r.memory_pairs.push_back({static_cast<std::uint32_t>(d & ((1ull << pw_) - 1)),
                                  static_cast<std::uint32_t>(d >> pw_)});
      }
    }
    return r;
  }

  // Lines the pair memory holds (L * PAIR_ROWS); read from the build.
  void set_pair_rows(std::uint32_t rows) { pair_rows_ = rows; }

  // Most compare-stage pairs one run() collects: past it, run() throws
  // CapacityExceeded (the cell engine passes max_pairs), so a cell of
  // coincident boxes stops at the limit instead of collecting n^2/2 lines.
  void set_pair_limit(std::uint64_t limit) { pair_limit_ = limit; }

 private:
  std::uint64_t stored_limit() const {
    return pair_rows_ ? static_cast<std::uint64_t>(pair_rows_) * lanes_ : ~0ull;
  }

  void tick() {
    top_->clk = 1;
    top_->eval();
    top_->clk = 0;
    top_->eval();
  }

  void collect(std::uint64_t cycle, RtlResult& r) {
    const std::uint64_t hit = top_->out_hit;
    if (!hit) return;
    for (unsigned l = 0; l < lanes_; ++l) {
      if (!((hit >> l) & 1)) continue;
      r.pairs.push_back({detail::bits(top_->out_a, l * pw_, pw_), detail::bits(top_->out_b, l * pw_, pw_)});
      r.pair_cycle.push_back(cycle);
    }
    if (r.pairs.size() > pair_limit_)
      throw CapacityExceeded("rtl: more than " + std::to_string(pair_limit_) +
                             " overlapping pairs in one run (max_pairs)");
  }

  RtlStep step(std::uint64_t cycle) {
    RtlStep s;
    s.cycle = cycle;
    if constexpr (requires(V v) { v.dbg_base; }) {
      // area-efficient: port 0 = i, port p = base + p - 1 (p = 2g + {0: A, 1: B})
      const std::uint32_t i = top_->dbg_i, base = top_->dbg_base;
      for (unsigned g = 0; g < m_; ++g) {
        s.port_a.push_back(g == 0 ? i : base + 2 * g - 1);
        s.port_b.push_back(base + 2 * g);
      }
    } else {
      for (unsigned g = 0; g < m_; ++g) {
        s.port_a.push_back(top_->dbg_addr_a);
        s.port_b.push_back(detail::bits(top_->dbg_addr_b, g * aw_, aw_));
        s.selector.push_back(detail::bits(top_->dbg_sel, g * 8, 8));
      }
    }
    return s;
  }

  Design design_;
  unsigned m_, depth_, lanes_ = 0, pw_ = 1, aw_ = 1;
  std::uint32_t capacity_ = 0, pair_rows_ = 0;
  std::uint64_t pair_limit_ = ~std::uint64_t{0};
  std::unique_ptr<VerilatedContext> ctx_;
  std::unique_ptr<V> top_;
};

}  // namespace hbp::rtl
