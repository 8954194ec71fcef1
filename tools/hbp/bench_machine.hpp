// SPDX-License-Identifier: MIT
#pragma once
// What ran the benchmark: CPU, cores, memory, OS, load, compiler, build
// flags and library versions, as key/value pairs in a stable order.
#include <string>
#include <utility>
#include <vector>

namespace hbp::cli {

using MachineDescription = std::vector<std::pair<std::string, std::string>>;

MachineDescription describe_machine();

// /proc/loadavg's line (the load now; "unknown" where there is none).
std::string read_load_average();

// "Intel(R) Xeon(R) Processor, 2 cores, GCC 12.2.0": one line for headers.
std::string machine_summary(const MachineDescription& m);

}  // namespace hbp::cli
