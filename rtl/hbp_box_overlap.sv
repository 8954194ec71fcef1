// One compare lane: the six comparators and the six-input AND of the paper's
// compare operation. Boxes are 192-bit words, coordinate c at [32*c +: 32]
// in the order min x, min y, min z, max x, max y, max z (hbp::Aabb layout).
//   hit = a.max >= b.min && a.min <= b.max   on all three axes (closed).
// Three ">=" cells (written as b.min <= a.max) and three "<=" cells.
module hbp_box_overlap (
    input  logic [191:0] a,
    input  logic [191:0] b,
    output logic         hit
);
  logic [2:0] ge_ok, le_ok;
  genvar ax;
  generate
    for (ax = 0; ax < 3; ax = ax + 1) begin : g_axis
      // a.max[ax] >= b.min[ax]
      hbp_fcmp_le u_ge (.a(b[32*ax +: 32]), .b(a[32*(ax+3) +: 32]), .le(ge_ok[ax]));
      // a.min[ax] <= b.max[ax]
      hbp_fcmp_le u_le (.a(a[32*ax +: 32]), .b(b[32*(ax+3) +: 32]), .le(le_ok[ax]));
    end
  endgenerate
  assign hit = &{ge_ok, le_ok};
endmodule
