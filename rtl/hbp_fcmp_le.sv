// IEEE-754 binary32 "a <= b", combinational, exactly as C++ `a <= b` on float:
//   * -0 and +0 compare equal (both-zero special case);
//   * any NaN operand gives 0 (unordered), as in IEEE-754 and C++;
//   * infinities and subnormals order as usual.
// ">=" is the same cell with its operands swapped: (a >= b) == (b <= a).
// The library rejects NaN before boxes reach an engine, so the NaN path is
// never exercised in the hybrid system; it is tested here for completeness.
//
// Method: map each float to an unsigned key whose integer order is the float
// order (negative: invert all bits; positive: set the sign bit), then one
// 32-bit unsigned compare (a carry chain on FPGAs).
module hbp_fcmp_le (
    input  logic [31:0] a,
    input  logic [31:0] b,
    output logic        le
);
  logic        a_nan, b_nan, both_zero;
  logic [31:0] ka, kb;

  assign a_nan     = (a[30:23] == 8'hFF) && (a[22:0] != 23'd0);
  assign b_nan     = (b[30:23] == 8'hFF) && (b[22:0] != 23'd0);
  assign both_zero = (a[30:0] == 31'd0) && (b[30:0] == 31'd0);
  assign ka        = a[31] ? ~a : {1'b1, a[30:0]};
  assign kb        = b[31] ? ~b : {1'b1, b[30:0]};
  assign le        = !a_nan && !b_nan && (both_zero || (ka <= kb));
endmodule
