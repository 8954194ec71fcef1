// SPDX-License-Identifier: MIT
// Area-efficient microarchitecture (paper 3.1.1, Fig. 1, Table 1).
//
// Buffer : 6m dual-port memories (m memory groups of six 32-bit memories,
//          one per coordinate), each holding all n boxes (replicated).
// Compare: 2m-1 lanes, each six float32 comparators (3 ">=", 3 "<=") and a
//          six-input AND: 6m-3 ">=", 6m-3 "<=", 2m-1 ANDs in total.
// Output : hits are written to the pair memory, one line per pair.
//
// Capacity: DEPTH boxes. Interface and timing: rtl/README.md.
/* verilator lint_off DECLFILENAME */
module hbp_area_efficient #(
    parameter int M         = 4,
    parameter int DEPTH     = 1024,
    parameter int PAIR_ROWS = 64,                      // pair memory: (2m-1)*PAIR_ROWS lines
    // derived, do not override
    parameter int L         = 2 * M - 1,               // compare lanes
    parameter int CAP       = DEPTH,                   // boxes
    parameter int PW        = (CAP > 1) ? $clog2(CAP) : 1,  // object index bits
    parameter int NW        = $clog2(CAP + 1),         // box count bits
    parameter int IW        = $clog2(CAP + 2 * M + 1) + 1,  // sequence index bits
    parameter int AW        = (DEPTH > 1) ? $clog2(DEPTH) : 1
) (
    input  logic              clk,
    input  logic              rst,          // synchronous, active high
    // control
    input  logic              clear,        // forget boxes, pairs and counters
    input  logic              load_valid,   // one box per cycle, index = n_loaded
    input  logic [191:0]      load_box,     // min x,y,z, max x,y,z (32 bits each, LSB first)
    input  logic              start,        // run all-pairs over the boxes loaded
    output logic              busy,
    output logic              done,         // stays high until clear
    output logic              load_error,   // a load past capacity was dropped
    output logic [NW-1:0]     n_loaded,
    // cycle counters (see README: what each phase counts)
    output logic [31:0]       cyc_load,
    output logic [31:0]       cyc_seq,
    output logic [31:0]       cyc_drain,
    output logic [31:0]       cyc_restart,  // always 0 here (many-object only)
    output logic [31:0]       cycles,       // cyc_seq + cyc_restart + cyc_drain (load excluded, as the models)
    // compare-stage output: the bus into the pair memory (lane l: a = i, b = j)
    output logic              out_valid,
    output logic [L-1:0]      out_hit,
    output logic [L*PW-1:0]   out_a,
    output logic [L*PW-1:0]   out_b,
    // pair memory read port
    input  logic              pair_pop,
    output logic              pair_rvalid,
    output logic [2*PW-1:0]   pair_rdata,   // {b, a}
    output logic [31:0]       pair_count,
    output logic              pair_overflow,
    // trace: this cycle's sequence step (port p address = p == 0 ? dbg_i : dbg_base + p - 1)
    output logic              dbg_step,
    output logic [IW-1:0]     dbg_i,
    output logic [IW-1:0]     dbg_base
);
  // ---------------------------------------------------------------- control
  logic          seq_step, seq_finish;
  logic [IW-1:0] seq_i, seq_base;
  logic [L-1:0]  seq_ok;
  logic          loading, in_load;

  assign dbg_step = seq_step;
  assign dbg_i    = seq_i;
  assign dbg_base = seq_base;

  hbp_ae_sequencer #(.M(M), .IW(IW)) u_seq (
      .clk(clk), .rst(rst || clear), .start(start && in_load),
      .n(IW'(n_loaded)), .step(seq_step), .obj_i(seq_i), .base(seq_base),
      .lane_ok(seq_ok), .finish(seq_finish));

  // Pipeline (= hbp::hw::PipelineLatencies defaults, depth 6): step at cycle
  // t -> memory array t+1 -> memory output register t+2 -> comparator stages
  // t+3, t+4 -> AND t+5 -> pair line on out_* and written at t+6.
  localparam int LAT = 6;

  // No row restarts here: cyc_restart stays 0.
  hbp_run_control #(.CAP(CAP), .NW(NW), .LAT(LAT), .RESTARTS(0)) u_ctl (
      .clk(clk), .rst(rst || clear), .load_valid(load_valid), .start(start),
      .seq_step(seq_step), .seq_bubble(1'b0), .seq_finish(seq_finish),
      .in_load(in_load), .loading(loading), .busy(busy), .done(done), .load_error(load_error),
      .n_loaded(n_loaded), .cyc_load(cyc_load), .cyc_seq(cyc_seq), .cyc_restart(cyc_restart),
      .cyc_drain(cyc_drain), .cycles(cycles));

  // ----------------------------------------------------------------- buffer
  // Group g: port A = sequence port 2g, port B = port 2g+1; during loading
  // every group's port A writes the same box at address n_loaded.
  /* verilator lint_off UNUSEDSIGNAL */
  logic [2*M*IW-1:0]   port_addr;   // port p's object index (high bits: beyond DEPTH)
  /* verilator lint_on UNUSEDSIGNAL */
  logic [2*M*192-1:0]  port_data;   // port p's box at [p*192 +: 192]
  genvar p, g, c;
  generate
    for (p = 0; p < 2 * M; p = p + 1) begin : g_port
      if (p == 0) begin : g_p0
        assign port_addr[0 +: IW] = seq_i;
      end else begin : g_pn
        assign port_addr[p*IW +: IW] = seq_base + IW'(p - 1);
      end
    end
    for (g = 0; g < M; g = g + 1) begin : g_group
      for (c = 0; c < 6; c = c + 1) begin : g_coord
        hbp_dpram #(.W(32), .DEPTH(DEPTH), .AW(AW)) u_mem (
            .clk(clk),
            .we_a(loading),
            .addr_a(loading ? n_loaded[AW-1:0] : port_addr[(2*g)*IW +: AW]),
            .wdata_a(load_box[32*c +: 32]),
            .rdata_a(port_data[(2*g)*192 + 32*c +: 32]),
            .addr_b(port_addr[(2*g+1)*IW +: AW]),
            .rdata_b(port_data[(2*g+1)*192 + 32*c +: 32]));
      end
    end
  endgenerate

  // ---------------------------------------------------------------- compare
  // Sideband of the step, delayed to meet its AND result (t+5).
  localparam int SBW = 1 + IW + IW + L;
  logic          s5_step;
  logic [IW-1:0] s5_i, s5_base;
  logic [L-1:0]  s5_ok, s5_hit;
  hbp_delay #(.W(SBW), .N(LAT - 1)) u_sideband (
      .clk(clk), .rst(rst || clear),
      .d({seq_step, seq_i, seq_base, seq_ok}),
      .q({s5_step, s5_i, s5_base, s5_ok}));

  genvar l;
  generate
    for (l = 0; l < L; l = l + 1) begin : g_lane
      hbp_box_overlap u_cmp (
          .clk(clk), .a(port_data[0 +: 192]), .b(port_data[(l+1)*192 +: 192]), .hit(s5_hit[l]));
    end
  endgenerate

  // Pair write stage.
  always_ff @(posedge clk) begin
    if (rst || clear) begin
      out_valid <= 1'b0;
      out_hit   <= '0;
    end else begin
      out_valid <= s5_step;
      out_hit   <= s5_step ? (s5_hit & s5_ok) : '0;
    end
    for (int k = 0; k < L; k = k + 1) begin
      out_a[k*PW +: PW] <= s5_i[PW-1:0];
      out_b[k*PW +: PW] <= PW'(s5_base + IW'(k));
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
  assign unused = ^{pair_available, s5_i[IW-1:PW]};
endmodule
/* verilator lint_on DECLFILENAME */
