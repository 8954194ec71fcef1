// SPDX-License-Identifier: MIT
#include "hbp/hw/hw_cell_engines.hpp"

#include <algorithm>
#include <mutex>
#include <cstdint>
#include <string>

#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/buffer_input_checks.hpp"
#include "hbp/hw/hardware_order_pairs.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp/software_engine.hpp"

namespace hbp::hw {
namespace {

class HardwareModelEngine final : public CellEngine {
 public:
  HardwareModelEngine(Design design, const ModelConfig& cfg, bool simulate)
      : design_(design), cfg_(cfg), simulate_(simulate) {
    validate(cfg_);
  }

  std::string name() const override {
    std::string n = design_ == Design::AreaEfficient ? "ae" : "mo";
    return simulate_ ? n + "-sim" : n;
  }
  std::uint32_t capacity() const override {
    // Object indices are 32-bit: a deeper buffer cannot be addressed anyway.
    return static_cast<std::uint32_t>(std::min<std::uint64_t>(buffer_capacity(design_, cfg_), UINT32_MAX));
  }
  std::uint32_t default_cell_limit() const override { return 1024; }
  double clock_hz() const override { return cfg_.clock_hz; }

  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override {
    if (simulate_) return simulate(cell, out);
    check_capacity(design_, cfg_, cell.size());
    if (design_ == Design::AreaEfficient) {
      area_efficient_order_pairs(cell, out, pair_limit_);
    } else {
      many_object_order_pairs(cell, cfg_.m, out, pair_limit_);
    }
    return {cycles_for(static_cast<std::uint32_t>(cell.size()))};
  }

  // The hybrid system's path. The pairs' set is what the hardware writes;
  // the fast path finds it with the SIMD sweep (same set, software order) and
  // charges the analytic cycles. The -sim engines keep the hardware's order.
  CellRun find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) override {
    if (simulate_) return CellEngine::find_owned_pairs(cell, region, out);
    check_capacity(design_, cfg_, cell.size());
    pairs_engine_.set_pair_limit(pair_limit_);
    pairs_engine_.find_owned_pairs(cell, region, out);
    return {cycles_for(static_cast<std::uint32_t>(cell.size()))};
  }

  std::uint64_t cycles_for(std::uint32_t n) const override {
    return analytic_cycles(design_, n, cfg_).total();
  }

  std::unique_ptr<CellEngine> clone() const override {
    return std::make_unique<HardwareModelEngine>(design_, cfg_, simulate_);
  }

 private:
  CellRun simulate(const BoxArray& cell, std::vector<Pair>& out) {
    // Models are built on first use: the fast path never pays for buffers.
    // The pair limit applies to the model's pair memory, before the
    // ownership filter: pairs found in one cell are distinct real pairs of
    // the frame, so more of them than max_pairs means the frame has more.
    if (design_ == Design::AreaEfficient) {
      if (!area_efficient_) area_efficient_ = std::make_unique<AreaEfficientModel>(cfg_);
      area_efficient_->set_pair_limit(pair_limit_);
      return {area_efficient_->run(cell, out).cycles.total()};
    }
    if (!many_object_) many_object_ = std::make_unique<ManyObjectModel>(cfg_);
    many_object_->set_pair_limit(pair_limit_);
    return {many_object_->run(cell, out).cycles.total()};
  }

  Design design_;
  ModelConfig cfg_;
  bool simulate_;
  std::unique_ptr<AreaEfficientModel> area_efficient_;
  std::unique_ptr<ManyObjectModel> many_object_;
  SoftwareEngine pairs_engine_;
};

}  // namespace

std::unique_ptr<CellEngine> make_area_efficient_engine(const ModelConfig& cfg, bool simulate) {
  return std::make_unique<HardwareModelEngine>(Design::AreaEfficient, cfg, simulate);
}

std::unique_ptr<CellEngine> make_many_object_engine(const ModelConfig& cfg, bool simulate) {
  return std::make_unique<HardwareModelEngine>(Design::ManyObject, cfg, simulate);
}

namespace {
std::unique_ptr<CellEngine> make_ae() { return make_area_efficient_engine({}, false); }
std::unique_ptr<CellEngine> make_mo() { return make_many_object_engine({}, false); }
std::unique_ptr<CellEngine> make_ae_sim() { return make_area_efficient_engine({}, true); }
std::unique_ptr<CellEngine> make_mo_sim() { return make_many_object_engine({}, true); }
}  // namespace

void register_cell_engines() {
  static std::once_flag once;
  std::call_once(once, [] {
    register_cell_engine("ae", &make_ae,
                         "area-efficient model, analytic cycles; on the hybrid path the software "
                         "engine's sweep finds the pairs");
    register_cell_engine("mo", &make_mo,
                         "many-object model, analytic cycles; on the hybrid path the software "
                         "engine's sweep finds the pairs");
    register_cell_engine("ae-sim", &make_ae_sim, "area-efficient model, every cycle simulated");
    register_cell_engine("mo-sim", &make_mo_sim, "many-object model, every cycle simulated");
  });
}

}  // namespace hbp::hw
