// rp_ewmm: the streaming EWMM component (thesis ch. 5, Fig. 5.2) for the
// riskplan FPGA shim. docs/rtl.md describes it; the register map is the one
// in docs/accel.md ("The streaming component and its register map") and
// accel/shim/component_regs.h, which the shim's mmio backend drives.
//
// A job: the processor loads kernels into weight slots through the CSR
// slave, programs the cut (a rectangle of map cells) and, per lane, a weight
// slot and a window in the cut, and writes START. The cut's cells then
// stream in, one per clock, in row-major order, either through the
// Avalon-ST sink (from a DMA) or through the STREAM register; each lane
// multiplies the cells inside its window by its kernel's weights and sums
// the exact products. DONE rises when the last cell has been added; the
// processor reads each lane's two sums. Nothing is rounded, so the sums are
// bit for bit those of the software model (accel/fixed_point.h).
//
// One clock, synchronous active-high reset, no delays and no initial blocks.
module rp_ewmm #(
    parameter int LANES = 8,  // 1..32
    parameter int W = 32,  // weight fraction bits
    parameter int M = 32,  // cell bits
    parameter int A = 80,  // accumulator bits, W + M + 12 <= A <= 128
    parameter int SLOTS = 4,  // kernel weight slots
    parameter int MAX_SIDE = 63,  // largest kernel side, <= 64
    parameter int CLOCK_HZ = 100_000_000,
    localparam int CW = (M <= 32) ? 32 : 64,  // stream bits per value
    localparam int SLOT_BITS = (SLOTS > 1) ? $clog2(SLOTS) : 1
) (
    input  logic            clk,
    input  logic            reset,
    // Avalon-MM CSR slave: 32-bit registers, word addresses, read latency 1,
    // no wait states.
    input  logic [     9:0] avs_address,
    input  logic            avs_read,
    output logic [    31:0] avs_readdata,
    input  logic            avs_write,
    input  logic [    31:0] avs_writedata,
    // Avalon-ST sink for the cut: one cell per beat, density in the low half.
    input  logic            asi_valid,
    output logic            asi_ready,
    /* verilator lint_off UNUSEDSIGNAL */  // bits above M of each half
    input  logic [2*CW-1:0] asi_data,
    /* verilator lint_on UNUSEDSIGNAL */
    // Level interrupt: STATUS.DONE.
    output logic            irq
);
  localparam logic [31:0] IdValue = 32'h52504B31;  // "RPK1"
  localparam logic [31:0] VersionValue = 32'h00010000;  // 1.0
  localparam int Replicas = (LANES + 1) / 2;
  localparam int LaneBits = (LANES > 1) ? $clog2(LANES) : 1;
  localparam int Depth = (1 << SLOT_BITS) * 4096;
  localparam int WordsPerCell = (M <= 32) ? 2 : 4;
  localparam logic [31:0] SlotWeights = MAX_SIDE * MAX_SIDE;

  // Word addresses of the registers (byte offset / 4).
  localparam logic [9:0] AddrId = 10'h000, AddrVersion = 10'h001, AddrCaps = 10'h002;
  localparam logic [9:0] AddrLimits = 10'h003, AddrCtrl = 10'h004, AddrStatus = 10'h005;
  localparam logic [9:0] AddrCutCols = 10'h006, AddrCutRows = 10'h007, AddrLaneMask = 10'h008;
  localparam logic [9:0] AddrCyclesLo = 10'h009, AddrCyclesHi = 10'h00A, AddrClockHz = 10'h00B;
  localparam logic [9:0] AddrWaddr = 10'h00C, AddrWdataLo = 10'h00D, AddrWdataHi = 10'h00E;
  localparam logic [9:0] AddrStream = 10'h010, AddrLaneBase = 10'h040;

  localparam logic [7:0] ErrBadLane = 8'd1, ErrStream = 8'd2, ErrWeightBusy = 8'd3;

  // ---- CSR state -----------------------------------------------------------
  logic busy, done, err;
  logic [7:0] err_code;
  logic [31:0] cut_cols, cut_rows, lane_mask, waddr, wdata_lo;
  logic [63:0] cycles;
  logic [31:0] lane_slot[LANES], lane_side[LANES], lane_col[LANES], lane_row[LANES];
  logic [A-1:0] acc_impact[LANES], acc_shelter[LANES];

  // ---- Stream state ----------------------------------------------------------
  logic [15:0] col_q, row_q;  // place in the cut of the next cell
  logic all_in;  // every cell of the cut has entered the pipeline
  logic s1_valid;  // a cell is in stage 1
  logic [1:0] word_cnt;  // words of the cell in progress (STREAM register)
  logic [31:0] word_buf[3];
  logic [M-1:0] density1, shelter1;  // the cell in stage 1

  // ---- Decode ----------------------------------------------------------------
  wire ctrl_write = avs_write && avs_address == AddrCtrl;
  wire ctrl_start = ctrl_write && avs_writedata[0];
  wire ctrl_reset = ctrl_write && avs_writedata[1];
  wire stream_write = avs_write && avs_address == AddrStream;
  wire weight_write = avs_write && avs_address == AddrWdataHi;
  wire lane_write = avs_write && avs_address >= AddrLaneBase &&
      {22'b0, avs_address} < {22'b0, AddrLaneBase} + 32'(LANES) * 16;
  /* verilator lint_off UNUSEDSIGNAL */  // only the lane number's bits
  wire [5:0] lane_word = avs_address[9:4] - AddrLaneBase[9:4];
  /* verilator lint_on UNUSEDSIGNAL */
  wire [LaneBits-1:0] lane_sel = lane_word[LaneBits-1:0];

  // ---- START checks: every lane in LANE_MASK must exist and have a slot, a
  // side in [1, MAX_SIDE] and a window inside the cut (RESET with START clears
  // the lanes first, so then every masked lane fails). Computed from the
  // registers alone, so the simulation re-evaluates it only when they change.
  logic [LANES-1:0] lane_bad;
  always_comb begin
    for (int l = 0; l < LANES; l++) begin
      lane_bad[l] = lane_mask[l] && (lane_slot[l] >= 32'(SLOTS) ||
          lane_side[l] == 0 || lane_side[l] > 32'(MAX_SIDE) ||
          {1'b0, lane_col[l]} + {1'b0, lane_side[l]} > {1'b0, cut_cols} ||
          {1'b0, lane_row[l]} + {1'b0, lane_side[l]} > {1'b0, cut_rows});
    end
  end
  wire any_lane = |lane_mask[LANES-1:0];
  wire mask_bad = (LANES < 32) ? (lane_mask >> LANES) != 0 : 1'b0;
  wire cut_bad = cut_cols > 32'hFFFF || cut_rows > 32'hFFFF;
  wire start_bad = |lane_bad || mask_bad || cut_bad || (ctrl_reset && any_lane);
  wire start_ok = ctrl_start && !start_bad;
  wire cut_empty = cut_cols == 0 || cut_rows == 0;

  // ---- Cells in: from the ST sink, or assembled from STREAM writes ----------
  wire stream_open = busy && !all_in;
  wire csr_fire = stream_write && stream_open && word_cnt == 2'(WordsPerCell - 1);
  assign asi_ready = stream_open && !stream_write;
  wire st_fire = asi_valid && asi_ready;
  wire fire = csr_fire || st_fire;
  logic [M-1:0] cell_density, cell_shelter;
  always_comb begin
    if (csr_fire) begin
      if (WordsPerCell == 2) begin
        cell_density = M'(word_buf[0]);
        cell_shelter = M'(avs_writedata);
      end else begin
        cell_density = M'({word_buf[1], word_buf[0]});
        cell_shelter = M'({avs_writedata, word_buf[2]});
      end
    end else begin
      cell_density = asi_data[M-1:0];
      cell_shelter = asi_data[CW+M-1:CW];
    end
  end
  wire last_cell = {16'b0, col_q} == cut_cols - 1 && {16'b0, row_q} == cut_rows - 1;

  // ---- Lanes and their weight RAMs (one RAM replica per pair of lanes) ------
  logic [11:0] widx[LANES];
  logic [W-1:0] weight[LANES];
  logic [SLOT_BITS+11:0] read_addr[LANES];
  wire weight_we = weight_write && !busy && waddr[31:16] < 16'(SLOTS) &&
      {16'b0, waddr[15:0]} < SlotWeights;
  wire [SLOT_BITS+11:0] write_addr = {waddr[16+SLOT_BITS-1:16], waddr[11:0]};

  for (genvar l = 0; l < LANES; l++) begin : g_lane
    assign read_addr[l] = {lane_slot[l][SLOT_BITS-1:0], widx[l]};
    rp_ewmm_lane #(
        .W(W),
        .M(M),
        .A(A)
    ) lane (
        .clk(clk),
        .clear(reset || ctrl_reset || ctrl_start),
        .arm(!reset && start_ok && lane_mask[l]),
        .win_col(lane_col[l][15:0]),
        .win_row(lane_row[l][15:0]),
        .win_side(lane_side[l][6:0]),
        .fire(fire),
        .col(col_q),
        .row(row_q),
        .widx(widx[l]),
        .weight(weight[l]),
        .density1(density1),
        .shelter1(shelter1),
        .acc_impact(acc_impact[l]),
        .acc_shelter(acc_shelter[l])
    );
  end

  for (genvar r = 0; r < Replicas; r++) begin : g_ram
    /* verilator lint_off UNUSEDSIGNAL */  // port B idles with an odd lane count
    logic [W-1:0] b_rdata;
    /* verilator lint_on UNUSEDSIGNAL */
    rp_weight_ram #(
        .WIDTH(W),
        .DEPTH(Depth)
    ) ram (
        .clk(clk),
        .a_we(weight_we),
        .a_addr(weight_we ? write_addr : read_addr[2*r]),
        .a_wdata(W'({avs_writedata, wdata_lo})),
        .a_rdata(weight[2*r]),
        .b_addr((2 * r + 1 < LANES) ? read_addr[(2*r+1)%LANES] : '0),
        .b_rdata(b_rdata)
    );
    if (2 * r + 1 < LANES) begin : g_b
      assign weight[2*r+1] = b_rdata;
    end
  end

  // ---- Control ---------------------------------------------------------------
  always_ff @(posedge clk) begin
    if (reset) begin
      busy <= 1'b0;
      done <= 1'b0;
      err <= 1'b0;
      err_code <= '0;
      cut_cols <= '0;
      cut_rows <= '0;
      lane_mask <= '0;
      waddr <= '0;
      wdata_lo <= '0;
      cycles <= '0;
      col_q <= '0;
      row_q <= '0;
      all_in <= 1'b0;
      s1_valid <= 1'b0;
      word_cnt <= '0;
    end else begin
      // Cycles from START to DONE of the last job.
      if (busy) cycles <= cycles + 64'd1;
      s1_valid <= fire;
      if (fire) begin
        density1 <= cell_density;
        shelter1 <= cell_shelter;
        if (last_cell) all_in <= 1'b1;
        if ({16'b0, col_q} == cut_cols - 1) begin
          col_q <= '0;
          row_q <= row_q + 16'd1;
        end else begin
          col_q <= col_q + 16'd1;
        end
      end
      // The last cell leaves stage 1 now and is added at this edge.
      if (busy && all_in && !s1_valid) begin
        busy <= 1'b0;
        done <= 1'b1;
      end

      if (avs_write) begin
        case (avs_address)
          AddrCutCols: cut_cols <= avs_writedata;
          AddrCutRows: cut_rows <= avs_writedata;
          AddrLaneMask: lane_mask <= avs_writedata;
          AddrWaddr: waddr <= avs_writedata;
          AddrWdataLo: wdata_lo <= avs_writedata;
          default: ;
        endcase
      end
      if (stream_write) begin
        if (!stream_open) begin
          busy <= 1'b0;
          done <= 1'b1;
          err <= 1'b1;
          err_code <= ErrStream;
        end else if (word_cnt == 2'(WordsPerCell - 1)) begin
          word_cnt <= '0;
        end else begin
          word_buf[word_cnt] <= avs_writedata;
          word_cnt <= word_cnt + 2'd1;
        end
      end
      if (weight_write) begin
        if (busy) begin
          // Weights are loaded between jobs: a lane may be reading them.
          busy <= 1'b0;
          done <= 1'b1;
          err <= 1'b1;
          err_code <= ErrWeightBusy;
        end else begin
          waddr[15:0] <= waddr[15:0] + 16'd1;
        end
      end
      if (ctrl_reset) begin
        busy <= 1'b0;
        done <= 1'b0;
        err <= 1'b0;
        err_code <= '0;
        all_in <= 1'b0;
        s1_valid <= 1'b0;
        word_cnt <= '0;
      end
      if (ctrl_start) begin
        col_q <= '0;
        row_q <= '0;
        all_in <= 1'b0;
        s1_valid <= 1'b0;
        word_cnt <= '0;
        if (start_bad) begin
          busy <= 1'b0;
          done <= 1'b1;
          err <= 1'b1;
          err_code <= ErrBadLane;
        end else begin
          busy <= !cut_empty;
          done <= cut_empty;
          err <= 1'b0;
          err_code <= '0;
          cycles <= '0;
        end
      end
    end
  end

  // Lane registers: written through the CSR slave, cleared by reset and RESET.
  always_ff @(posedge clk) begin
    if (reset || ctrl_reset) begin
      for (int l = 0; l < LANES; l++) begin
        lane_slot[l] <= '0;
        lane_side[l] <= '0;
        lane_col[l] <= '0;
        lane_row[l] <= '0;
      end
    end else if (lane_write) begin
      case (avs_address[3:0])
        4'd0: lane_slot[lane_sel] <= avs_writedata;
        4'd1: lane_side[lane_sel] <= avs_writedata;
        4'd2: lane_col[lane_sel] <= avs_writedata;
        4'd3: lane_row[lane_sel] <= avs_writedata;
        default: ;
      endcase
    end
  end

  assign irq = done;

  // ---- CSR reads (registered: read latency 1) -----------------------------------
  // Word w of a sum, zero-extended to 128 bits.
  function automatic logic [31:0] sum_word(input logic [A-1:0] sum, input logic [1:0] w);
    logic [127:0] wide = 128'(sum);
    return wide[32*w+:32];
  endfunction
  always_ff @(posedge clk) begin
    if (avs_read) begin
      case (avs_address)
        AddrId: avs_readdata <= IdValue;
        AddrVersion: avs_readdata <= VersionValue;
        AddrCaps: avs_readdata <= {8'(A), 8'(M), 8'(W), 8'(LANES)};
        AddrLimits: avs_readdata <= {16'(SLOTS), 16'(MAX_SIDE)};
        AddrStatus: avs_readdata <= {16'b0, err_code, 5'b0, err, done, busy};
        AddrCutCols: avs_readdata <= cut_cols;
        AddrCutRows: avs_readdata <= cut_rows;
        AddrLaneMask: avs_readdata <= lane_mask;
        AddrCyclesLo: avs_readdata <= cycles[31:0];
        AddrCyclesHi: avs_readdata <= cycles[63:32];
        AddrClockHz: avs_readdata <= 32'(CLOCK_HZ);
        AddrWaddr: avs_readdata <= waddr;
        default: begin
          avs_readdata <= '0;
          if ({22'b0, avs_address} >= {22'b0, AddrLaneBase} &&
              {22'b0, avs_address} < {22'b0, AddrLaneBase} + 32'(LANES) * 16) begin
            case (avs_address[3:0])
              4'd0: avs_readdata <= lane_slot[lane_sel];
              4'd1: avs_readdata <= lane_side[lane_sel];
              4'd2: avs_readdata <= lane_col[lane_sel];
              4'd3: avs_readdata <= lane_row[lane_sel];
              4'd4, 4'd5, 4'd6, 4'd7:
                avs_readdata <= sum_word(acc_impact[lane_sel], avs_address[1:0]);
              4'd8, 4'd9, 4'd10, 4'd11:
                avs_readdata <= sum_word(acc_shelter[lane_sel], avs_address[1:0]);
              default: ;
            endcase
          end
        end
      endcase
    end
  end
endmodule
