// A simple dual-port RAM with registered reads: port A writes or reads, port
// B reads. Written in the form Quartus infers as one M10K true-dual-port
// block per 10 Kbit on a Cyclone V (old data on a read during a write); no
// reset, as block RAM has none.
module rp_weight_ram #(
    parameter int WIDTH = 32,
    parameter int DEPTH = 16384,
    localparam int AW = $clog2(DEPTH)
) (
    input  logic             clk,
    input  logic             a_we,
    input  logic [   AW-1:0] a_addr,
    input  logic [WIDTH-1:0] a_wdata,
    output logic [WIDTH-1:0] a_rdata,
    input  logic [   AW-1:0] b_addr,
    output logic [WIDTH-1:0] b_rdata
);
  logic [WIDTH-1:0] mem[DEPTH];

  always_ff @(posedge clk) begin
    if (a_we) mem[a_addr] <= a_wdata;
    a_rdata <= mem[a_addr];
    b_rdata <= mem[b_addr];
  end
endmodule
