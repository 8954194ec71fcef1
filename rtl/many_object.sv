// SPDX-License-Identifier: MIT
// Many-object microarchitecture (paper 3.1.2, Fig. 2, Tables 2 and 3).
//
// Buffer : 6m dual-port memories (m memory groups of six 32-bit memories);
//          box x is stored once, in group x mod m at address x div m.
// Reorder: m multiplexer groups (6m 32-bit multiplexers, here m 192-bit
//          ones): lane j takes group (j + kr) mod m's port-B box.
// Compare: m lanes, each six float32 comparators and a six-input AND:
//          3m ">=", 3m "<=", m ANDs.
// Output : hits are written to the pair memory, one line per pair.
//
// Capacity: DEPTH * m boxes. Interface and timing: rtl/README.md.
/* verilator lint_off DECLFILENAME */
module hbp_many_object #(
    parameter int M         = 4,
    parameter int DEPTH     = 1024,
    parameter int PAIR_ROWS = 64,                      // pair memory: m*PAIR_ROWS lines
    parameter bit ROW_DRAIN = 1,                       // = ModelConfig::row_change_drains_pipeline
    // derived, do not override
    parameter int L         = M,                       // compare lanes
    parameter int CAP       = DEPTH * M,               // boxes
    parameter int PW        = (CAP > 1) ? $clog2(CAP) : 1,
    parameter int NW        = $clog2(CAP + 1),
    parameter int IW        = $clog2(CAP + 2 * M + 1) + 1,
    parameter int AW        = (DEPTH > 1) ? $clog2(DEPTH) : 1
) (
    input  logic              clk,
    input  logic              rst,
    input  logic              clear,
    input  logic              load_valid,
    input  logic [191:0]      load_box,
    input  logic              start,
    output logic              busy,
    output logic              done,
    output logic              load_error,
    output logic [NW-1:0]     n_loaded,
    output logic [31:0]       cyc_load,
    output logic [31:0]       cyc_seq,
    output logic [31:0]       cyc_drain,
    output logic [31:0]       cyc_restart,
    output logic [31:0]       cycles,       // cyc_seq + cyc_restart + cyc_drain (load excluded, as the models)
    output logic              out_valid,
    output logic [L-1:0]      out_hit,
    output logic [L*PW-1:0]   out_a,
    output logic [L*PW-1:0]   out_b,
    input  logic              pair_pop,
    output logic              pair_rvalid,
    output logic [2*PW-1:0]   pair_rdata,
    output logic [31:0]       pair_count,
    output logic              pair_overflow,
    // trace: this cycle's sequence step
    output logic              dbg_step,
    output logic [AW-1:0]     dbg_addr_a,   // every group's port A
    output logic [M*AW-1:0]   dbg_addr_b,   // group g's port B
    output logic [IW-1:0]     dbg_offset,   // k
    output logic [M*8-1:0]    dbg_sel       // lane j's selector (at this step)
);
  logic            seq_step, seq_finish;
  logic [AW-1:0]   seq_addr_a;
  logic [M*AW-1:0] seq_addr_b;
  logic [IW-1:0]   seq_rb, seq_k;
  logic [M*8-1:0]  seq_sel;
  logic [L-1:0]    seq_ok;
  logic            loading, in_load;
  logic            seq_bubble;
  // load position: group ld_g, address ld_a (box n_loaded)
  logic [7:0]      ld_g;
  logic [AW-1:0]   ld_a;

  assign dbg_step   = seq_step;
  assign dbg_addr_a = seq_addr_a;
  assign dbg_addr_b = seq_addr_b;
  assign dbg_offset = seq_k;
  assign dbg_sel    = seq_sel;

  // Pipeline (= hbp::hw::PipelineLatencies defaults, depth 7): step at t ->
  // memory array t+1 -> memory output register t+2 -> reorder register t+3
  // -> comparator stages t+4, t+5 -> AND t+6 -> pair line on out_* and
  // written at t+7.
  localparam int LAT = 7;

  hbp_mo_sequencer #(.M(M), .AW(AW), .IW(IW), .RESTART(ROW_DRAIN ? LAT : 0)) u_seq (
      .clk(clk), .rst(rst || clear), .start(start && in_load),
      .n(IW'(n_loaded)), .step(seq_step), .bubble(seq_bubble), .addr_a(seq_addr_a), .addr_b(seq_addr_b),
      .row_base(seq_rb), .offset(seq_k), .sel(seq_sel), .lane_ok(seq_ok),
      .finish(seq_finish));

  hbp_run_control #(.CAP(CAP), .NW(NW), .LAT(LAT)) u_ctl (
      .clk(clk), .rst(rst || clear), .load_valid(load_valid), .start(start),
      .seq_step(seq_step), .seq_bubble(seq_bubble), .seq_finish(seq_finish),
      .in_load(in_load), .loading(loading), .busy(busy), .done(done), .load_error(load_error),
      .n_loaded(n_loaded), .cyc_load(cyc_load), .cyc_seq(cyc_seq), .cyc_restart(cyc_restart),
      .cyc_drain(cyc_drain), .cycles(cycles));

  // Load position: box n_loaded goes to group n_loaded mod m, address n_loaded div m.
  always_ff @(posedge clk) begin
    if (rst || clear) begin
      ld_g <= '0;
      ld_a <= '0;
    end else if (loading) begin
      if (ld_g == 8'(M - 1)) begin
        ld_g <= '0;
        ld_a <= ld_a + 1'b1;
      end else begin
        ld_g <= ld_g + 8'd1;
      end
    end
  end

  // ----------------------------------------------------------------- buffer
  logic [M*192-1:0] data_a, data_b;  // group g's port A / B box
  genvar g, c;
  generate
    for (g = 0; g < M; g = g + 1) begin : g_group
      for (c = 0; c < 6; c = c + 1) begin : g_coord
        hbp_dpram #(.W(32), .DEPTH(DEPTH), .AW(AW)) u_mem (
            .clk(clk),
            .we_a(loading && ld_g == 8'(g)),
            .addr_a(loading ? ld_a : seq_addr_a),
            .wdata_a(load_box[32*c +: 32]),
            .rdata_a(data_a[g*192 + 32*c +: 32]),
            .addr_b(seq_addr_b[g*AW +: AW]),
            .rdata_b(data_b[g*192 + 32*c +: 32]));
      end
    end
  endgenerate

  // ---------------------------------------------------------------- reorder
  // Selectors travel with the memory read (2 cycles); the reorder register
  // holds lane j's A box (group j) and B box (group sel_j).
  logic [M*8-1:0]   s2_sel;
  logic [M*192-1:0] s3_a, s3_b;
  hbp_delay #(.W(M * 8), .N(2)) u_sel (.clk(clk), .rst(rst || clear), .d(seq_sel), .q(s2_sel));
  // Lane j's multiplexer as an AND-OR of one-hot selects (no index
  // arithmetic: a variable part-select's sel*192 would infer a multiplier).
  logic [M*192-1:0] mux_b;
  always_comb begin
    mux_b = '0;
    for (int j = 0; j < M; j = j + 1) begin
      for (int src = 0; src < M; src = src + 1) begin
        if (s2_sel[8*j +: 8] == 8'(src)) mux_b[j*192 +: 192] = mux_b[j*192 +: 192] | data_b[src*192 +: 192];
      end
    end
  end
  always_ff @(posedge clk) begin
    s3_a <= data_a;
    s3_b <= mux_b;
  end

  // ---------------------------------------------------------------- compare
  localparam int SBW = 1 + IW + IW + L;
  logic          s6_step;
  logic [IW-1:0] s6_rb, s6_k;
  logic [L-1:0]  s6_ok, s6_hit;
  hbp_delay #(.W(SBW), .N(LAT - 1)) u_sideband (
      .clk(clk), .rst(rst || clear),
      .d({seq_step, seq_rb, seq_k, seq_ok}),
      .q({s6_step, s6_rb, s6_k, s6_ok}));

  genvar l;
  generate
    for (l = 0; l < L; l = l + 1) begin : g_lane
      hbp_box_overlap u_cmp (
          .clk(clk), .a(s3_a[l*192 +: 192]), .b(s3_b[l*192 +: 192]), .hit(s6_hit[l]));
    end
  endgenerate

  // Pair write stage.
  always_ff @(posedge clk) begin
    if (rst || clear) begin
      out_valid <= 1'b0;
      out_hit   <= '0;
    end else begin
      out_valid <= s6_step;
      out_hit   <= s6_step ? (s6_hit & s6_ok) : '0;
    end
    for (int k = 0; k < L; k = k + 1) begin
      out_a[k*PW +: PW] <= PW'(s6_rb + IW'(k));
      out_b[k*PW +: PW] <= PW'(s6_rb + IW'(k) + s6_k);
    end
  end

  // ------------------------------------------------------------ pair memory
  logic [31:0] pair_available;
  hbp_pair_memory #(.L(L), .PW(PW), .ROWS(PAIR_ROWS), .CW(32)) u_pairs (
      .clk(clk), .rst(rst), .clear(clear),
      .in_hit(out_hit), .in_a(out_a), .in_b(out_b),
      .pop(pair_pop), .rvalid(pair_rvalid), .rdata(pair_rdata),
      .count(pair_count), .available(pair_available), .overflow(pair_overflow));

  logic unused;
  assign unused = ^{pair_available};
endmodule
/* verilator lint_on DECLFILENAME */
