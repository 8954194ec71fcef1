// SPDX-License-Identifier: MIT
// main() of every GoogleTest binary: registers the hardware models' cell
// engines by name ("ae", "mo", "ae-sim", "mo-sim"), as the hbp tool and the
// Python module do at start-up, then runs the tests.
#include <gtest/gtest.h>

#include "hbp/hw/hw_cell_engines.hpp"

int main(int argc, char** argv) {
  hbp::hw::register_cell_engines();
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
