// SPDX-License-Identifier: MIT
// Pair output memory: "one line per colliding pair", written in lane order
// with up to L lines per cycle and no back-pressure (the compare pipeline
// never stalls), read back in the order written, one line per `pop` (a
// FIFO read port over a linear memory; `clear` empties it for the next cell).
//
// Structure: L banks of ROWS lines, line x lives in bank x mod L at row
// x div L. A cycle's hits are compacted (lane l's rank = hits below it) and
// rotated to banks (wbank + rank) mod L, so every bank takes at most one
// write per cycle: each bank is a simple one-write one-read memory (block
// RAM). Capacity L*ROWS lines; lines past it are dropped and `overflow`
// stays set until `clear` (size ROWS for the densest cell you run, or drain
// while running).
module hbp_pair_memory #(
    parameter int L    = 7,
    parameter int PW   = 10,   // bits per object index
    parameter int ROWS = 64,
    parameter int CW   = 32    // count width
) (
    input  logic              clk,
    input  logic              rst,
    input  logic              clear,
    input  logic [L-1:0]      in_hit,
    input  logic [L*PW-1:0]   in_a,
    input  logic [L*PW-1:0]   in_b,
    input  logic              pop,
    output logic              rvalid,
    output logic [2*PW-1:0]   rdata,     // {b, a}
    output logic [CW-1:0]     count,     // lines written (including dropped)
    output logic [CW-1:0]     available, // lines written and not yet popped
    output logic              overflow
);
  localparam int BW = (L > 1) ? $clog2(L) : 1;
  localparam int RW = (ROWS > 1) ? $clog2(ROWS) : 1;
  localparam int RC = BW + 1;  // rank width: 0..L

  // rank of each lane among this cycle's hits
  logic [L*RC-1:0] rank;
  logic [RC-1:0]   total;
  always_comb begin
    logic [RC-1:0] acc;
    acc = '0;
    for (int l = 0; l < L; l = l + 1) begin
      rank[l*RC +: RC] = acc;
      acc = acc + RC'(in_hit[l]);
    end
    total = acc;
  end

  logic [BW-1:0]   wbank, rbank;
  logic [RW:0]     wrow, rrow;   // one extra bit: row == ROWS means full
  logic [L*2*PW-1:0] bank_q;
  logic [BW-1:0]   rbank_q;
  logic            pop_q;

  genvar b;
  generate
    for (b = 0; b < L; b = b + 1) begin : g_bank
      // rank that lands in this bank and the row it goes to
      logic [RC-1:0]   want;
      logic [RW:0]     row;
      logic            we;
      logic [2*PW-1:0] wd;
      logic [2*PW-1:0] mem[0:ROWS-1];
      logic [2*PW-1:0] q;
      assign bank_q[b*2*PW +: 2*PW] = q;
      /* verilator lint_off CMPCONST */
      assign want = (BW'(b) >= wbank) ? RC'(BW'(b) - wbank) : RC'(L) - RC'(wbank) + RC'(b);
      assign row  = (BW'(b) >= wbank) ? wrow : wrow + 1'b1;
      /* verilator lint_on CMPCONST */
      always_comb begin
        we = 1'b0;
        wd = '0;
        for (int l = 0; l < L; l = l + 1) begin
          if (in_hit[l] && rank[l*RC +: RC] == want) begin
            we = 1'b1;
            wd = {in_b[l*PW +: PW], in_a[l*PW +: PW]};
          end
        end
      end
      always_ff @(posedge clk) begin
        if (we && !clear && row < (RW+1)'(ROWS)) mem[row[RW-1:0]] <= wd;
        if (pop && rbank == BW'(b)) q <= mem[rrow[RW-1:0]];
      end
    end
  endgenerate

  assign rvalid = pop_q;
  assign rdata  = bank_q[rbank_q*2*PW +: 2*PW];

  always_ff @(posedge clk) begin
    if (rst || clear) begin
      wbank     <= '0;
      wrow      <= '0;
      rbank     <= '0;
      rrow      <= '0;
      count     <= '0;
      available <= '0;
      overflow  <= 1'b0;
      pop_q     <= 1'b0;
      rbank_q   <= '0;
    end else begin
      pop_q   <= pop && (available != 0);
      rbank_q <= rbank;
      if ((32'(wbank) + 32'(total)) >= 32'(L)) begin
        wbank <= BW'(32'(wbank) + 32'(total) - 32'(L));
        if (wrow < (RW+1)'(ROWS)) wrow <= wrow + 1'b1;  // saturates when full
      end else begin
        wbank <= BW'(32'(wbank) + 32'(total));
      end
      count <= count + CW'(total);
      if (count + CW'(total) > CW'(L * ROWS)) overflow <= 1'b1;
      if (pop && available != 0) begin
        if (rbank == BW'(L - 1)) begin
          rbank <= '0;
          rrow  <= rrow + 1'b1;
        end else begin
          rbank <= rbank + 1'b1;
        end
      end
      available <= available + CW'(total) - CW'(pop && available != 0);
    end
  end
endmodule
