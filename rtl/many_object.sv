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
    output logic [31:0]       cycles,
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
  typedef enum logic [1:0] {S_LOAD, S_RUN, S_DRAIN, S_DONE} state_t;
  state_t state;

  logic            seq_step, seq_finish;
  logic [AW-1:0]   seq_addr_a;
  logic [M*AW-1:0] seq_addr_b;
  logic [IW-1:0]   seq_rb, seq_k;
  logic [M*8-1:0]  seq_sel;
  logic [L-1:0]    seq_ok;
  logic            loading;
  logic [1:0]      drain_left;
  // load position: group ld_g, address ld_a (box n_loaded)
  logic [7:0]      ld_g;
  logic [AW-1:0]   ld_a;

  assign loading    = (state == S_LOAD) && load_valid && (32'(n_loaded) < 32'(CAP));
  assign busy       = (state == S_RUN) || (state == S_DRAIN);
  assign done       = (state == S_DONE);
  assign cycles     = cyc_load + cyc_seq + cyc_drain;
  assign dbg_step   = seq_step;
  assign dbg_addr_a = seq_addr_a;
  assign dbg_addr_b = seq_addr_b;
  assign dbg_offset = seq_k;
  assign dbg_sel    = seq_sel;

  hbp_mo_sequencer #(.M(M), .AW(AW), .IW(IW)) u_seq (
      .clk(clk), .rst(rst || clear), .start(start && state == S_LOAD),
      .n(IW'(n_loaded)), .step(seq_step), .addr_a(seq_addr_a), .addr_b(seq_addr_b),
      .row_base(seq_rb), .offset(seq_k), .sel(seq_sel), .lane_ok(seq_ok),
      .finish(seq_finish));

  // Pipeline: step at t -> memory data at t+1 -> reorder register at t+2 ->
  // compare result registered, on out_* and written at t+3.
  localparam int LAT = 3;

  always_ff @(posedge clk) begin
    if (rst || clear) begin
      state      <= S_LOAD;
      n_loaded   <= '0;
      load_error <= 1'b0;
      cyc_load   <= '0;
      cyc_seq    <= '0;
      cyc_drain  <= '0;
      drain_left <= '0;
      ld_g       <= '0;
      ld_a       <= '0;
    end else begin
      case (state)
        S_LOAD: begin
          if (loading) begin
            n_loaded <= n_loaded + 1'b1;
            cyc_load <= cyc_load + 1;
            if (ld_g == 8'(M - 1)) begin
              ld_g <= '0;
              ld_a <= ld_a + 1'b1;
            end else begin
              ld_g <= ld_g + 8'd1;
            end
          end else if (load_valid) begin
            load_error <= 1'b1;
          end
          if (start) state <= S_RUN;
        end
        S_RUN: begin
          if (seq_step) cyc_seq <= cyc_seq + 1;
          if (seq_finish) begin
            // n < 2: nothing in flight, no drain. Otherwise this is drain
            // cycle 1 of LAT; done rises the cycle after the last one.
            if (cyc_seq == 0 && !seq_step) state <= S_DONE;
            else begin
              cyc_drain  <= cyc_drain + 1;
              state      <= (LAT > 1) ? S_DRAIN : S_DONE;
              drain_left <= 2'(LAT - 2);
            end
          end
        end
        S_DRAIN: begin
          cyc_drain <= cyc_drain + 1;
          if (drain_left == 0) state <= S_DONE;
          else drain_left <= drain_left - 1'b1;
        end
        default: ;
      endcase
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
  logic          s1_step, s2_step;
  logic [IW-1:0] s1_rb, s1_k, s2_rb, s2_k;
  logic [M*8-1:0] s1_sel;
  logic [L-1:0]  s1_ok, s2_ok, s2_hit;
  logic [M*192-1:0] s2_a, s2_b;

  always_ff @(posedge clk) begin
    if (rst || clear) begin
      s1_step <= 1'b0;
      s2_step <= 1'b0;
    end else begin
      s1_step <= seq_step;
      s2_step <= s1_step;
    end
    s1_rb  <= seq_rb;
    s1_k   <= seq_k;
    s1_sel <= seq_sel;
    s1_ok  <= seq_ok;
    s2_rb  <= s1_rb;
    s2_k   <= s1_k;
    s2_ok  <= s1_ok;
    s2_a   <= data_a;
    for (int j = 0; j < M; j = j + 1) begin
      s2_b[j*192 +: 192] <= data_b[s1_sel[8*j +: 8]*192 +: 192];
    end
  end

  // ---------------------------------------------------------------- compare
  genvar l;
  generate
    for (l = 0; l < L; l = l + 1) begin : g_lane
      hbp_box_overlap u_cmp (
          .a(s2_a[l*192 +: 192]), .b(s2_b[l*192 +: 192]), .hit(s2_hit[l]));
    end
  endgenerate

  always_ff @(posedge clk) begin
    if (rst || clear) begin
      out_valid <= 1'b0;
      out_hit   <= '0;
    end else begin
      out_valid <= s2_step;
      out_hit   <= s2_step ? (s2_hit & s2_ok) : '0;
    end
    for (int k = 0; k < L; k = k + 1) begin
      out_a[k*PW +: PW] <= PW'(s2_rb + IW'(k));
      out_b[k*PW +: PW] <= PW'(s2_rb + IW'(k) + s2_k);
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
