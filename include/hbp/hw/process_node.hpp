// SPDX-License-Identifier: MIT
#pragma once
// Process nodes for the silicon estimates: the synthesised node (OSU 0.18 um)
// and the nodes its figures are scaled to. The scale factors are published
// device figures, cited in docs/hardware.md ("Silicon"):
//   * area: the ratio of the nodes' published 6T SRAM bit-cell areas, applied
//     to logic and memory alike (one published density measure per node);
//   * switched energy: C V^2 with C proportional to the linear feature size
//     (the square root of the area ratio) and the node's nominal supply.
// Leakage is not scaled: a figure at a scaled node is switching energy only.
#include <span>
#include <string>

namespace hbp::hw {

struct ProcessNode {
  const char* name;          // "180nm", "28nm", "5nm"
  const char* label;         // the process, in words
  double vdd;                // nominal supply, V
  double sram_6t_cell_um2;   // published single-port 6T bit cell
};

// The synthesised node first, then the scaled ones.
std::span<const ProcessNode> process_nodes();
const ProcessNode& synthesis_node();
// Throws InvalidInput naming the accepted nodes.
const ProcessNode& find_process_node(const std::string& name);

// Factors from the synthesis node to `to`.
double area_scale(const ProcessNode& to);
double energy_scale(const ProcessNode& to);

}  // namespace hbp::hw
