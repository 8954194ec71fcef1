#pragma once
// The paper's Table 4 (Woulfe & Manzke), milliseconds per frame, transcribed
// from the paper's text: CPU = Bullet's btDbvtBroadphase on a 2 GHz
// quad-core AMD Opteron 2350, GPU = Bullet's OpenCL sweep and prune on a
// GeForce GTX 670, and the two microarchitectures modelled at 500 MHz with
// m = 16, without spatial partitioning ("none") or with the cell size given.
// kNone marks a blank cell (configuration not run by the paper).
#include <array>
#include <cstdint>
#include <limits>

namespace hbp::cli {

struct PaperTable4Row {
  std::uint32_t n;
  double cpu, gpu;
  double ae_none, ae_1024;
  double mo_none, mo_1024, mo_2048, mo_4096, mo_8192, mo_16384;
};

inline constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

inline constexpr std::array<PaperTable4Row, 20> kPaperTable4 = {{
    {100, 0.2213, 0.9732, 0.0005, kNone, 0.0008, kNone, kNone, kNone, kNone, kNone},
    {200, 0.4478, 0.9982, 0.0016, kNone, 0.0029, kNone, kNone, kNone, kNone, kNone},
    {300, 0.7990, 1.0347, 0.0033, kNone, 0.0062, kNone, kNone, kNone, kNone, kNone},
    {400, 0.9994, 1.0441, 0.0057, kNone, 0.0107, kNone, kNone, kNone, kNone, kNone},
    {500, 1.2966, 1.0302, 0.0087, kNone, 0.0165, kNone, kNone, kNone, kNone, kNone},
    {600, 1.5770, 1.0727, 0.0124, kNone, 0.0236, kNone, kNone, kNone, kNone, kNone},
    {700, 1.9871, 1.0796, 0.0168, kNone, 0.0319, kNone, kNone, kNone, kNone, kNone},
    {800, 2.5760, 1.0889, 0.0217, kNone, 0.0414, kNone, kNone, kNone, kNone, kNone},
    {900, 2.9700, 1.1072, 0.0273, kNone, 0.0522, kNone, kNone, kNone, kNone, kNone},
    {1000, 3.1694, 1.0945, 0.0336, kNone, 0.0643, kNone, kNone, kNone, kNone, kNone},
    {2000, 6.0023, 1.2040, kNone, 0.0423, 0.2535, 0.0804, kNone, kNone, kNone, kNone},
    {4000, 14.2332, 1.4039, kNone, 0.0913, 1.0070, 0.1727, 0.4036, kNone, kNone, kNone},
    {8000, 30.7177, 1.9585, kNone, 0.1665, 4.0140, 0.3153, 0.6270, 1.7638, kNone, kNone},
    {16000, 69.8204, 3.6801, kNone, 0.3074, 16.0280, 0.5821, 1.2199, 2.5936, 8.2487, kNone},
    {32000, 159.5770, 8.3066, kNone, 0.5676, kNone, 1.0749, 2.2525, 4.7891, 15.2312, 36.9132},
    {64000, 375.3380, 22.8188, kNone, 1.0481, kNone, 1.9848, 4.1592, 8.8431, 28.1244, 68.1603},
    {128000, 834.9720, 67.5312, kNone, 1.9353, kNone, 3.6649, 7.6800, 16.3288, 51.9317, 125.8579},
    {256000, 1940.2600, 187.3310, kNone, 3.5735, kNone, 6.7672, 14.1811, 30.1512, 95.8919, 232.3967},
    {512000, 4423.3300, 605.7710, kNone, 6.5985, kNone, 12.4957, 26.1853, 55.6742, 177.0645, 429.1206},
    {1024000, 9897.0100, 1958.8776, kNone, 12.1841, kNone, 23.0732, 48.3512, 102.8025, 326.9497, 792.3714},
}};

// The row for n, or nullptr when the paper has none.
inline const PaperTable4Row* paper_table4_row(std::uint32_t n) {
  for (const auto& r : kPaperTable4)
    if (r.n == n) return &r;
  return nullptr;
}

}  // namespace hbp::cli
