// SPDX-License-Identifier: MIT
#pragma once
// The two microarchitecture models as cell engines of the hybrid system.
// register_cell_engines() enters them in the core's engine registry
// (make_cell_engine) under these names:
//   "ae", "mo"          simulate = false (what benchmarks use): analytic
//                       cycles (analytic_cycles()), no model run. On the
//                       hybrid path (find_owned_pairs) the pairs come from the
//                       software engine's SIMD sweep (same set, software
//                       order); alone (find_pairs) from a scalar all-pairs
//                       loop in the hardware's output order.
//   "ae-sim", "mo-sim"  simulate = true: every cycle of the model simulated
//                       (verification, traces), pairs in the hardware's order.
// Both report the same pair set and identical cycles.
#include <memory>

#include "hbp/cell_engine.hpp"
#include "hbp/hw/model_config.hpp"

namespace hbp::hw {

std::unique_ptr<CellEngine> make_area_efficient_engine(const ModelConfig& cfg = {},
                                                       bool simulate = false);

// Registers "ae", "mo", "ae-sim" and "mo-sim" (the paper's configuration,
// ModelConfig{}) with hbp::register_cell_engine. Idempotent; call it before
// making these engines by name (the hbp tool, the Python module and the
// tests do at start-up).
void register_cell_engines();
std::unique_ptr<CellEngine> make_many_object_engine(const ModelConfig& cfg = {},
                                                    bool simulate = false);

// Registers "ae", "mo", "ae-sim" and "mo-sim" (the paper's configuration,
// ModelConfig{}) with hbp::register_cell_engine. Idempotent; call it before
// making these engines by name (the hbp tool, the Python module and the
// tests do at start-up).
void register_cell_engines();

}  // namespace hbp::hw
