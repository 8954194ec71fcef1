// SPDX-License-Identifier: MIT
#pragma once
// The two microarchitectures of the paper's cell-based broad phase.
#include <string>

namespace hbp::hw {

enum class Design { AreaEfficient, ManyObject };

// "area-efficient" / "many-object": the names used in reports and JSON.
const char* design_name(Design d);
// Accepts the report names and the engine names "ae" / "mo"; throws
// InvalidInput listing the accepted names otherwise.
Design parse_design(const std::string& name);

}  // namespace hbp::hw
