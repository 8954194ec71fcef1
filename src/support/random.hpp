// SPDX-License-Identifier: MIT
#pragma once
// The one random-number scheme of the library, tools and benchmarks
// (scenarios, narrow-phase random pairs, benchmark queries): splitmix64 and
// portable draws, so the same seed gives the same sequence on every compiler
// and library (std::uniform_real_distribution does not promise that). Scene
// generation depends on this exact sequence: changing a draw changes every
// seeded scene and the figures measured on it.
#include <cmath>
#include <cstdint>

namespace hbp {

class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed * 0x9E3779B97F4A7C15ull + 0x2545F4914F6CDD1Dull) {}

  std::uint64_t next() {  // splitmix64
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  std::uint32_t below(std::uint32_t n) {
    return static_cast<std::uint32_t>((static_cast<unsigned __int128>(next()) * n) >> 64);
  }
  double gaussian() {  // Box-Muller, one value per call
    double u1 = uniform();
    if (u1 <= 0) u1 = 0x1.0p-53;
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  std::uint64_t state_;
};

}  // namespace hbp
