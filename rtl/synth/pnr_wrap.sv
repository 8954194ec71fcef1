// SPDX-License-Identifier: MIT
// Place-and-route wrapper: the area-efficient top behind a handful of pins
// (an iCE40 package has far fewer pins than the core's 192-bit load bus and
// pair ports). Boxes shift in serially; the pair memory's read data and the
// compare lanes fold into two pins, so no logic is optimised away. Only for
// resource and maximum-frequency estimates (rtl/synth/resources.sh --pnr).
/* verilator lint_off DECLFILENAME */
module hbp_pnr_wrap #(
    parameter int M     = 1,
    parameter int DEPTH = 256
) (
    input  logic clk,
    input  logic rst,
    input  logic ser_in,      // box bits, LSB first
    input  logic ser_shift,
    input  logic load,        // load the shifted-in box
    input  logic start,
    input  logic clear,
    input  logic pop,
    output logic done,
    output logic busy,
    output logic pair_bit,
    output logic hit_any
);
  localparam int L  = 2 * M - 1;
  localparam int PW = $clog2(DEPTH);
  logic [191:0]      box;
  logic [2*PW-1:0]   rdata;
  logic [L-1:0]      out_hit;
  logic              rvalid, ovf, lerr, ovalid;
  logic [31:0]       c_load, c_seq, c_restart, c_drain, c_total, pcount;
  logic [L*PW-1:0]   oa, ob;
  logic [$clog2(DEPTH+1)-1:0] nl;
  logic              dstep;
  logic [$clog2(DEPTH + 2 * M + 1):0] di, db;

  always_ff @(posedge clk) if (ser_shift) box <= {ser_in, box[191:1]};

  hbp_area_efficient #(.M(M), .DEPTH(DEPTH), .PAIR_ROWS(64)) u_core (
      .clk(clk), .rst(rst), .clear(clear), .load_valid(load), .load_box(box), .start(start),
      .busy(busy), .done(done), .load_error(lerr), .n_loaded(nl),
      .cyc_load(c_load), .cyc_seq(c_seq), .cyc_drain(c_drain), .cyc_restart(c_restart),
      .cycles(c_total), .out_valid(ovalid), .out_hit(out_hit), .out_a(oa), .out_b(ob),
      .pair_pop(pop), .pair_rvalid(rvalid), .pair_rdata(rdata), .pair_count(pcount),
      .pair_overflow(ovf), .dbg_step(dstep), .dbg_i(di), .dbg_base(db));

  always_ff @(posedge clk) begin
    pair_bit <= ^{rdata, rvalid, ovf, lerr, c_total, pcount, nl};
    hit_any  <= |out_hit ^ ^{oa, ob, ovalid, c_load, c_seq, c_restart, c_drain, dstep, di, db};
  end
endmodule
/* verilator lint_on DECLFILENAME */
