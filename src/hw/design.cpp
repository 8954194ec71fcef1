// SPDX-License-Identifier: MIT
#include "hbp/hw/design.hpp"

#include "hbp/error.hpp"

namespace hbp::hw {

const char* design_name(Design d) {
  return d == Design::AreaEfficient ? "area-efficient" : "many-object";
}

Design parse_design(const std::string& name) {
  if (name == "area-efficient" || name == "ae") return Design::AreaEfficient;
  if (name == "many-object" || name == "mo") return Design::ManyObject;
  throw InvalidInput("unknown microarchitecture '" + name +
                     "' (known: area-efficient or ae, many-object or mo)");
}

}  // namespace hbp::hw
