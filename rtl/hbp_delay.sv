// SPDX-License-Identifier: MIT
// N-cycle delay line of W bits (N = 0: a wire). Carries a step's sideband
// (valid, indices, lane masks, selectors) alongside the datapath stages.
module hbp_delay #(
    parameter int W = 1,
    parameter int N = 1
) (
    input  logic         clk,
    input  logic         rst,    // clears the line
    input  logic [W-1:0] d,
    output logic [W-1:0] q
);
  generate
    if (N == 0) begin : g_wire
      assign q = d;
    end else if (N == 1) begin : g_one
      always_ff @(posedge clk) q <= rst ? '0 : d;
    end else begin : g_regs
      logic [N*W-1:0] r;   // stage k at [k*W +: W]
      always_ff @(posedge clk) begin
        if (rst) r <= '0;
        else r <= {r[(N-1)*W-1:0], d};
      end
      assign q = r[(N-1)*W +: W];
    end
  endgenerate
endmodule
