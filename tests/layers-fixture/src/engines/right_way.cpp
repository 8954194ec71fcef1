// SPDX-License-Identifier: MIT
// Fixture: an engines file including only what engines may (never compiled).
#include <vector>

#include "engines/box_kernels.hpp"
#include "hbp/box_array.hpp"
#include "hbp/software_engine.hpp"
