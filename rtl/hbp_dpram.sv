// SPDX-License-Identifier: MIT
// Dual-port memory with ports A and B, as in the paper: port A reads and
// writes (the buffer's initialisation writes through A), port B only reads.
// Reads take two cycles, as the C++ models' memory_read = 2: the array read
// register and an output register (a block RAM's optional output register,
// which 500 MHz needs). Read-first on A. Written so that Yosys maps the array
// onto one true-dual-port block RAM (Xilinx RAMB18E1/RAMB36E1); on iCE40,
// whose SB_RAM40_4K has one read and one write port, Yosys duplicates it
// (one copy per read port).
module hbp_dpram #(
    parameter int W     = 32,
    parameter int DEPTH = 1024,
    parameter int AW    = (DEPTH > 1) ? $clog2(DEPTH) : 1
) (
    input  logic          clk,
    input  logic          we_a,
    input  logic [AW-1:0] addr_a,
    input  logic [W-1:0]  wdata_a,
    output logic [W-1:0]  rdata_a,
    input  logic [AW-1:0] addr_b,
    output logic [W-1:0]  rdata_b
);
  logic [W-1:0] mem[0:DEPTH-1];
  logic [W-1:0] q_a, q_b;

  always_ff @(posedge clk) begin
    if (we_a) mem[addr_a] <= wdata_a;
    q_a <= mem[addr_a];
  end

  always_ff @(posedge clk) begin
    q_b <= mem[addr_b];
  end

  always_ff @(posedge clk) begin
    rdata_a <= q_a;
    rdata_b <= q_b;
  end
endmodule
