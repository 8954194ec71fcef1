// SPDX-License-Identifier: MIT
// IEEE-754 binary32 "a <= b", exactly as C++ `a <= b` on float:
//   * -0 and +0 compare equal (both-zero special case);
//   * any NaN operand gives 0 (unordered), as in IEEE-754 and C++;
//   * infinities and subnormals order as usual.
// ">=" is the same cell with its operands swapped: (a >= b) == (b <= a).
// The library and the C++ models reject NaN before boxes reach an engine, so
// the NaN path never matters in the hybrid system; it is tested here anyway.
//
// Method: map each float to an unsigned key whose integer order is the float
// order (negative: invert all bits; positive: set the sign bit), then one
// 32-bit unsigned compare (a carry chain on FPGAs). hbp_fcmp_le_parts is the
// first pipeline stage (the magnitude compare and special-case detection);
// the fix-up `le = ordered && (both_zero || key_le)` is the second.
/* verilator lint_off DECLFILENAME */
module hbp_fcmp_le_parts (
    input  logic [31:0] a,
    input  logic [31:0] b,
    output logic        ordered,    // neither operand is NaN
    output logic        both_zero,  // a and b are +-0
    output logic        key_le      // key(a) <= key(b)
);
  logic [31:0] ka, kb;
  logic        a_nan, b_nan;
  assign a_nan     = (a[30:23] == 8'hFF) && (a[22:0] != 23'd0);
  assign b_nan     = (b[30:23] == 8'hFF) && (b[22:0] != 23'd0);
  assign ordered   = !a_nan && !b_nan;
  assign both_zero = (a[30:0] == 31'd0) && (b[30:0] == 31'd0);
  assign ka        = a[31] ? ~a : {1'b1, a[30:0]};
  assign kb        = b[31] ? ~b : {1'b1, b[30:0]};
  assign key_le    = ka <= kb;
endmodule
/* verilator lint_on DECLFILENAME */

// Combinational form (used by the comparator unit test).
/* verilator lint_off DECLFILENAME */
module hbp_fcmp_le (
    input  logic [31:0] a,
    input  logic [31:0] b,
    output logic        le
);
  logic ordered, both_zero, key_le;
  hbp_fcmp_le_parts u_parts (.a(a), .b(b), .ordered(ordered), .both_zero(both_zero), .key_le(key_le));
  assign le = ordered && (both_zero || key_le);
endmodule
/* verilator lint_on DECLFILENAME */
