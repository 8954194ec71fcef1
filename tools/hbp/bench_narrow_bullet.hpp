// SPDX-License-Identifier: MIT
#pragma once
// hbp bench narrow: our narrow phase against Bullet's dispatcher on the
// paper scene's candidate pairs (one thread, both measured in the same run).
#include <CLI/CLI.hpp>

namespace hbp::cli {

void add_bench_narrow(CLI::App* bench);

}  // namespace hbp::cli
