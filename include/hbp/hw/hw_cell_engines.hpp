#pragma once
// The two microarchitecture models as cell engines of the hybrid system
// ("ae" and "mo" in make_cell_engine).
//
// simulate = false (what benchmarks use): the pairs come from a scalar
// all-pairs loop that visits pairs in the hardware's output order, and the
// cycles from analytic_cycles(). simulate = true: every cycle of the model is
// simulated (verification, traces). Both report identical pairs in identical
// order and identical cycles.
#include <memory>

#include "hbp/cell_engine.hpp"
#include "hbp/hw/model_config.hpp"

namespace hbp::hw {

std::unique_ptr<CellEngine> make_area_efficient_engine(const ModelConfig& cfg = {},
                                                       bool simulate = false);
std::unique_ptr<CellEngine> make_many_object_engine(const ModelConfig& cfg = {},
                                                    bool simulate = false);

}  // namespace hbp::hw
