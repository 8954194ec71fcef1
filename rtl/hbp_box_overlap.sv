// SPDX-License-Identifier: MIT
// One compare lane: the six float32 comparators and the six-input AND of the
// paper's compare operation, pipelined as the C++ models' default latencies
// (hbp::hw::PipelineLatencies): compare = 2 stages, AND = 1 stage.
//   stage 1 register: per comparator {ordered, both_zero, key_le}
//   stage 2 register: the six comparator results
//   stage 3 register: hit = AND of the six
// Boxes are 192-bit words, coordinate c at [32*c +: 32] in the order min x,
// min y, min z, max x, max y, max z (hbp::Aabb layout).
//   hit = a.max >= b.min && a.min <= b.max   on all three axes (closed).
// Three ">=" cells (written as b.min <= a.max) and three "<=" cells.
module hbp_box_overlap (
    input  logic         clk,
    input  logic [191:0] a,
    input  logic [191:0] b,
    output logic         hit    // three cycles after a, b
);
  logic [5:0] ordered, both_zero, key_le;     // [ax]: ">=" on axis ax; [3+ax]: "<="
  logic [5:0] s1_ordered, s1_both_zero, s1_key_le;
  logic [5:0] s2_le;
  genvar ax;
  generate
    for (ax = 0; ax < 3; ax = ax + 1) begin : g_axis
      // a.max[ax] >= b.min[ax]   <=>   b.min[ax] <= a.max[ax]
      hbp_fcmp_le_parts u_ge (.a(b[32*ax +: 32]), .b(a[32*(ax+3) +: 32]),
          .ordered(ordered[ax]), .both_zero(both_zero[ax]), .key_le(key_le[ax]));
      // a.min[ax] <= b.max[ax]
      hbp_fcmp_le_parts u_le (.a(a[32*ax +: 32]), .b(b[32*(ax+3) +: 32]),
          .ordered(ordered[3+ax]), .both_zero(both_zero[3+ax]), .key_le(key_le[3+ax]));
    end
  endgenerate
  always_ff @(posedge clk) begin
    s1_ordered   <= ordered;
    s1_both_zero <= both_zero;
    s1_key_le    <= key_le;
    s2_le        <= s1_ordered & (s1_both_zero | s1_key_le);
    hit          <= &s2_le;
  end
endmodule
