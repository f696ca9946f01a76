// One multiply-accumulate lane of the streaming EWMM component (docs/rtl.md).
//
// The cut streams past every lane in row-major order. A lane whose window
// (side x side cells at (c0, r0) in the cut) contains the current cell reads
// the next weight of its kernel slot: the window is visited in row-major
// order too, so the lane's weight index simply counts the cells it has taken
// (no address arithmetic, and nothing to zero: the lane never reads past its
// own side x side weights). The products are exact (W + M bits) and so are
// the A-bit sums, so the order of accumulation cannot change a bit.
//
// Pipeline, one cell per clock:
//   stage 0  window test, weight read issued at {slot, widx}
//   stage 1  weight arrives from the RAM; products registered
//   stage 2  products added to the accumulators
module rp_ewmm_lane #(
    parameter int W = 32,
    parameter int M = 32,
    parameter int A = 80
) (
    input  logic          clk,
    // START or RESET: accumulators, weight index and pipeline cleared; with
    // `arm` the lane takes part in the job whose window is given.
    input  logic          clear,
    input  logic          arm,
    input  logic [  15:0] win_col,
    input  logic [  15:0] win_row,
    input  logic [   6:0] win_side,
    // Stage 0: the cell entering the pipeline and its place in the cut.
    input  logic          fire,
    input  logic [  15:0] col,
    input  logic [  15:0] row,
    output logic [  11:0] widx,
    // Stage 1: the weight read for the previous cell, and that cell's values.
    input  logic [ W-1:0] weight,
    input  logic [ M-1:0] density1,
    input  logic [ M-1:0] shelter1,
    output logic [ A-1:0] acc_impact,
    output logic [ A-1:0] acc_shelter
);
  logic en;
  logic [15:0] c0, r0;
  logic [16:0] c1, r1;  // one past the window
  logic hit0, hit1, hit2;
  logic [W+M-1:0] prod_impact, prod_shelter;

  assign hit0 = fire && en && col >= c0 && {1'b0, col} < c1 && row >= r0 && {1'b0, row} < r1;

  always_ff @(posedge clk) begin
    if (clear) begin
      en <= arm;
      c0 <= win_col;
      r0 <= win_row;
      c1 <= {1'b0, win_col} + {10'b0, win_side};
      r1 <= {1'b0, win_row} + {10'b0, win_side};
      widx <= '0;
      hit1 <= 1'b0;
      hit2 <= 1'b0;
      acc_impact <= '0;
      acc_shelter <= '0;
    end else begin
      if (hit0) widx <= widx + 12'd1;
      hit1 <= hit0;
      hit2 <= hit1;
      prod_impact <= hit1 ? (W + M)'(weight) * (W + M)'(density1) : '0;
      prod_shelter <= hit1 ? (W + M)'(weight) * (W + M)'(shelter1) : '0;
      if (hit2) begin
        acc_impact <= acc_impact + A'(prod_impact);
        acc_shelter <= acc_shelter + A'(prod_shelter);
      end
    end
  end
endmodule
