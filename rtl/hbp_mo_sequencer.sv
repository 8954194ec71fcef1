// SPDX-License-Identifier: MIT
// Address sequencer of the many-object microarchitecture (paper 3.1.2,
// Table 3). Object x lives in memory group x mod m at address x div m
// (Table 2). Row a holds objects a*m .. a*m+m-1, read on every group's port
// A. Offset k runs 1 .. n-1-a*m; with k = kq*m + kr, group g's port B reads
// address a + kq + (g < kr), so the B ports together hold objects
// a*m+k .. a*m+k+m-1, and the reorder multiplexer of lane j selects group
// (j + kr) mod m: lane j compares object a*m+j with object a*m+j+k.
// Lanes whose partner is >= n are removed. Steps for row a: n - a*m - 1
// (rows with no step are skipped); total = the paper's sum.
// RESTART > 0: after a row's last step the sequencer holds for RESTART
// cycles (`bubble`) so the pipeline empties before the A address changes,
// as the C++ model's row_change_drains_pipeline (RESTART = pipeline depth).
module hbp_mo_sequencer #(
    parameter int M  = 4,
    parameter int AW = 10,  // memory address width
    parameter int IW = 16,  // index width, holds n-1 + m
    parameter int RESTART = 0
) (
    input  logic              clk,
    input  logic              rst,
    input  logic              start,
    input  logic [IW-1:0]     n,
    output logic              step,
    output logic              bubble,    // holding between rows
    output logic [AW-1:0]     addr_a,    // every group's port A
    output logic [M*AW-1:0]   addr_b,    // group g's port B at [g*AW +: AW]
    output logic [IW-1:0]     row_base,  // a*m: object index of lane 0's A side
    output logic [IW-1:0]     offset,    // k
    output logic [M*8-1:0]    sel,       // lane j's multiplexer selector at [8*j +: 8]
    output logic [M-1:0]      lane_ok,   // lane j: a*m + j + k < n
    output logic              finish
);
  localparam int KQ0 = (M == 1) ? 1 : 0;  // k = 1 split as kq*m + kr
  localparam int KR0 = (M == 1) ? 0 : 1;

  logic          run;
  logic [7:0]    hold;
  logic [AW-1:0] a_q, kq_q;
  logic [7:0]    kr_q;
  logic [IW-1:0] rb_q, k_q;

  assign step     = run && hold == 0;
  assign bubble   = run && hold != 0;
  assign addr_a   = a_q;
  assign row_base = rb_q;
  assign offset   = k_q;

  genvar g;
  generate
    for (g = 0; g < M; g = g + 1) begin : g_grp
      assign addr_b[g*AW +: AW] = a_q + kq_q + ((8'(g) < kr_q) ? AW'(1) : AW'(0));
      // (j + kr) mod m, with j + kr < 2m
      assign sel[8*g +: 8] = (8'(g) + kr_q >= 8'(M)) ? 8'(g) + kr_q - 8'(M) : 8'(g) + kr_q;
      assign lane_ok[g] = (rb_q + IW'(g) + k_q) < n;
    end
  endgenerate

  always_ff @(posedge clk) begin
    finish <= 1'b0;
    if (rst) begin
      run  <= 1'b0;
      hold <= '0;
      a_q  <= '0;
      kq_q <= '0;
      kr_q <= '0;
      rb_q <= '0;
      k_q  <= '0;
    end else if (start) begin
      a_q    <= '0;
      rb_q   <= '0;
      k_q    <= IW'(1);
      kq_q   <= AW'(KQ0);
      kr_q   <= 8'(KR0);
      run    <= (n >= IW'(2));
      hold   <= '0;
      finish <= (n < IW'(2));
    end else if (bubble) begin
      hold <= hold - 8'd1;
    end else if (run) begin
      if (rb_q + k_q + IW'(1) >= n) begin
        // row done; the next row has n - (a+1)*m - 1 steps
        if (rb_q + IW'(M) + IW'(1) >= n) begin
          run    <= 1'b0;
          finish <= 1'b1;
        end else begin
          hold <= 8'(RESTART);
          a_q  <= a_q + AW'(1);
          rb_q <= rb_q + IW'(M);
          k_q  <= IW'(1);
          kq_q <= AW'(KQ0);
          kr_q <= 8'(KR0);
        end
      end else begin
        k_q <= k_q + IW'(1);
        if (kr_q == 8'(M - 1)) begin
          kr_q <= '0;
          kq_q <= kq_q + AW'(1);
        end else begin
          kr_q <= kr_q + 8'd1;
        end
      end
    end
  end
endmodule
