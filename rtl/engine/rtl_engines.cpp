// SPDX-License-Identifier: MIT
// CellEngine implementations over the Verilated RTL builds ae_m16 / mo_m16.
#include "hbp/rtl/rtl_engines.hpp"

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "hbp/cell_engine.hpp"
#include "hbp/error.hpp"
#include "hbp_rtl_models.hpp"
#include "rtl_cycles.hpp"

namespace hbp::rtl {
namespace {

constexpr double kClockHz = 500e6;  // the paper's adapted clock

template <class Model>
class RtlCellEngine final : public CellEngine {
 public:
  RtlCellEngine() : driver_(Model::design, Model::m, Model::depth) {}

  std::string name() const override {
    return Model::design == Design::kAreaEfficient ? "rtl-ae" : "rtl-mo";
  }
  std::uint32_t capacity() const override { return driver_.capacity(); }
  // Many-object: the full 16,384 would cost ~8.4M simulated cycles per cell;
  // 1024 keeps a frame to seconds while exercising the same hardware.
  std::uint32_t default_cell_limit() const override { return 1024; }
  double clock_hz() const override { return kClockHz; }

  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override {
    if (cell.size() > capacity())
      throw CapacityExceeded(name() + ": cell of " + std::to_string(cell.size()) +
                             " boxes exceeds the RTL capacity " + std::to_string(capacity()));
    driver_.set_pair_limit(pair_limit_);
    RtlResult r = driver_.run(cell);
    out.insert(out.end(), r.pairs.begin(), r.pairs.end());
    return CellRun{r.cycles};
  }

  std::uint64_t cycles_for(std::uint32_t n) const override {
    return total_cycles(Model::design, n, Model::m);
  }

  std::unique_ptr<CellEngine> clone() const override {
    return std::make_unique<RtlCellEngine<Model>>();
  }

 private:
  RtlDriver<typename Model::V> driver_;
};

std::unique_ptr<CellEngine> make_ae() {
  return std::make_unique<RtlCellEngine<models::ae_m16>>();
}
std::unique_ptr<CellEngine> make_mo() {
  return std::make_unique<RtlCellEngine<models::mo_m16>>();
}

}  // namespace

void register_rtl_engines() {
  static std::once_flag once;
  std::call_once(once, [] {
    register_cell_engine("rtl-ae", &make_ae, "Verilated RTL of the area-efficient design (m = 16, depth 1024)");
    register_cell_engine("rtl-mo", &make_mo, "Verilated RTL of the many-object design (m = 16, depth 1024)");
  });
}

}  // namespace hbp::rtl
