// SPDX-License-Identifier: MIT
#pragma once
// `hbp hw activity|asic|energy`: the silicon estimates of both
// microarchitectures (standard-cell flow reports + SRAM model + node scaling).
#include <CLI/CLI.hpp>

namespace hbp::cli {

void setup_hw_activity(CLI::App& hw);
void setup_hw_asic(CLI::App& hw);
void setup_hw_energy(CLI::App& hw);

}  // namespace hbp::cli
