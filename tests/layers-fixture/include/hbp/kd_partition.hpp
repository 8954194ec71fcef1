// SPDX-License-Identifier: MIT
#pragma once
// Fixture: a public header of the partition room reaching up into the
// pipeline (never compiled).
#include "hbp/box_array.hpp"
#include "hbp/hybrid_broadphase.hpp"
