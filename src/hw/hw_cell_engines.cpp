#include "hbp/hw/hw_cell_engines.hpp"

#include <string>

#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/hardware_order_pairs.hpp"

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
    return static_cast<std::uint32_t>(buffer_capacity(design_, cfg_));
  }
  std::uint32_t default_cell_limit() const override { return 1024; }
  double clock_hz() const override { return cfg_.clock_hz; }

  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override {
    check_capacity(cell.size());
    if (design_ == Design::AreaEfficient) {
      area_efficient_order_pairs(cell, out);
    } else {
      many_object_order_pairs(cell, cfg_.m, out);
    }
    return {cycles_for(static_cast<std::uint32_t>(cell.size()))};
  }

  std::uint64_t cycles_for(std::uint32_t n) const override {
    return analytic_cycles(design_, n, cfg_).total();
  }

  std::unique_ptr<CellEngine> clone() const override {
    return std::make_unique<HardwareModelEngine>(design_, cfg_, simulate_);
  }

 private:
  void check_capacity(std::size_t n) const {
    if (n > capacity()) {
      throw CapacityExceeded(std::string(design_name(design_)) + " model (m = " +
                             std::to_string(cfg_.m) + ", depth = " + std::to_string(cfg_.depth) +
                             ") holds at most " + std::to_string(capacity()) +
                             " objects; the cell has " + std::to_string(n));
    }
  }

  Design design_;
  ModelConfig cfg_;
  bool simulate_;
};

}  // namespace

std::unique_ptr<CellEngine> make_area_efficient_engine(const ModelConfig& cfg, bool simulate) {
  return std::make_unique<HardwareModelEngine>(Design::AreaEfficient, cfg, simulate);
}

std::unique_ptr<CellEngine> make_many_object_engine(const ModelConfig& cfg, bool simulate) {
  return std::make_unique<HardwareModelEngine>(Design::ManyObject, cfg, simulate);
}

}  // namespace hbp::hw
