// SPDX-License-Identifier: MIT
// Fixture for the check_layers_catches_wrong_way test: an engines file that
// includes the hardware models (engines may not depend on hw). Never compiled.
#include "hbp/cell_engine.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
