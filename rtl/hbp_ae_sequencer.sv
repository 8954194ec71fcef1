// SPDX-License-Identifier: MIT
// Address sequencer of the area-efficient microarchitecture (paper 3.1.1,
// Table 1). 2m ports: port 0 is memory group 0's A, port p >= 1 is group
// p/2's A (p even) or B (p odd). Port 0 holds object i; ports 1..2m-1 hold
// base, base+1, ..., base+2m-2. Each step compares i with those 2m-1 objects
// (lane l: i against base+l); lanes whose object is >= n are removed.
//   start: i = 0, base = 1
//   step : if base + (2m-1) >= n: i += 1, base = i + 2   (next object)
//          else                   base += 2m-1
//   last step: i == n-2 and base + (2m-1) >= n
// Steps for object i: ceil((n-1-i)/(2m-1)); total = the paper's sum.
// n < 2 gives no step (`finish` is raised the cycle after `start`).
module hbp_ae_sequencer #(
    parameter int M  = 4,
    parameter int IW = 12   // index width, holds n-1 + 2m-1
) (
    input  logic              clk,
    input  logic              rst,
    input  logic              start,
    input  logic [IW-1:0]     n,
    output logic              step,      // a sequence step is issued this cycle
    output logic [IW-1:0]     obj_i,     // port 0 (group 0 A)
    output logic [IW-1:0]     base,      // port 1 (group 0 B); port p = base + p - 1
    output logic [2*M-2:0]    lane_ok,   // lane l: base + l < n
    output logic              finish     // pulses the cycle after the last step
);
  localparam int L = 2 * M - 1;
  logic          run;
  logic [IW-1:0] i_q, base_q;

  assign step  = run;
  assign obj_i = i_q;
  assign base  = base_q;

  genvar l;
  generate
    for (l = 0; l < L; l = l + 1) begin : g_lane
      assign lane_ok[l] = (base_q + IW'(l)) < n;
    end
  endgenerate

  always_ff @(posedge clk) begin
    finish <= 1'b0;
    if (rst) begin
      run    <= 1'b0;
      i_q    <= '0;
      base_q <= '0;
    end else if (start) begin
      i_q    <= '0;
      base_q <= IW'(1);
      run    <= (n >= IW'(2));
      finish <= (n < IW'(2));
    end else if (run) begin
      if (base_q + IW'(L) >= n) begin
        if (i_q + IW'(2) >= n) begin
          run    <= 1'b0;
          finish <= 1'b1;
        end else begin
          i_q    <= i_q + IW'(1);
          base_q <= i_q + IW'(2);
        end
      end else begin
        base_q <= base_q + IW'(L);
      end
    end
  end
endmodule
