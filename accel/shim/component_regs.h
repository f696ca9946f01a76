// The register map of the streaming EWMM component (docs/accel.md,
// "Register map"): an Avalon-MM CSR slave of 32-bit registers at byte
// offsets from the component's base. The mmio backend programs it; the
// ComponentModel and the RTL (accel/rtl/rp_ewmm.sv) implement it.
//
// A job: write kernels into weight slots (WADDR, then WDATA_LO/WDATA_HI per
// weight; WADDR increments after each WDATA_HI), program the cut size, the
// active lanes and each lane's slot, side and window origin in the cut, set
// CTRL.START, then write the cut's cells to STREAM in row-major order (per
// cell: the density word(s), then the shelter word(s); one word per value
// when M <= 32, else low word first). When the last cell has been added the
// component sets STATUS.DONE; the results are read from the lanes'
// RES_IMPACT / RES_SHELTER words (least significant first).
#ifndef RISKPLAN_ACCEL_SHIM_COMPONENT_REGS_H_
#define RISKPLAN_ACCEL_SHIM_COMPONENT_REGS_H_

#include <cstdint>

namespace riskplan::accel::regs {

inline constexpr uint32_t kIdValue = 0x52504B31;       // "RPK1"
inline constexpr uint32_t kVersionValue = 0x00010000;  // 1.0

inline constexpr uint32_t kId = 0x000;        // RO
inline constexpr uint32_t kVersion = 0x004;   // RO major << 16 | minor
inline constexpr uint32_t kCaps = 0x008;      // RO [7:0] lanes, [15:8] W, [23:16] M, [31:24] A
inline constexpr uint32_t kLimits = 0x00C;    // RO [15:0] largest kernel side, [31:16] weight slots
inline constexpr uint32_t kCtrl = 0x010;      // WO bit 0 START, bit 1 RESET
inline constexpr uint32_t kStatus = 0x014;    // RO bit 0 BUSY, bit 1 DONE, bit 2 ERROR, [15:8] code
inline constexpr uint32_t kCutCols = 0x018;   // RW cells per cut row
inline constexpr uint32_t kCutRows = 0x01C;   // RW cut rows
inline constexpr uint32_t kLaneMask = 0x020;  // RW bit l: lane l takes part in the job
inline constexpr uint32_t kCyclesLo = 0x024;  // RO cycles from START to DONE of the last job
inline constexpr uint32_t kCyclesHi = 0x028;  // RO
inline constexpr uint32_t kClockHz = 0x02C;   // RO component clock (Hz)
inline constexpr uint32_t kWaddr = 0x030;     // RW [31:16] slot, [15:0] weight index
inline constexpr uint32_t kWdataLo = 0x034;   // WO weight bits [31:0]
inline constexpr uint32_t kWdataHi = 0x038;   // WO weight bits [63:32]; writes the weight
inline constexpr uint32_t kStream = 0x040;    // WO map stream (see above)

inline constexpr uint32_t kCtrlStart = 1u << 0;
inline constexpr uint32_t kCtrlReset = 1u << 1;
inline constexpr uint32_t kStatusBusy = 1u << 0;
inline constexpr uint32_t kStatusDone = 1u << 1;
inline constexpr uint32_t kStatusError = 1u << 2;

// Error codes in STATUS[15:8].
inline constexpr uint32_t kErrorNone = 0;
inline constexpr uint32_t kErrorBadLane =
    1;  // a lane's window leaves the cut, its slot or side is out of range, a lane in
        // LANE_MASK does not exist, or the cut is wider or taller than 65535 cells
inline constexpr uint32_t kErrorStream = 2;      // STREAM written with no job taking cells
inline constexpr uint32_t kErrorWeightBusy = 3;  // WDATA_HI written while a job runs

// Per-lane registers: base kLaneBase + l * kLaneStride.
inline constexpr uint32_t kLaneBase = 0x100;
inline constexpr uint32_t kLaneStride = 0x40;
inline constexpr uint32_t kLaneSlot = 0x00;     // RW weight slot
inline constexpr uint32_t kLaneSide = 0x04;     // RW kernel side (cells)
inline constexpr uint32_t kLaneCol = 0x08;      // RW window origin: column in the cut
inline constexpr uint32_t kLaneRow = 0x0C;      // RW window origin: row in the cut
inline constexpr uint32_t kLaneImpact = 0x10;   // RO 4 words
inline constexpr uint32_t kLaneShelter = 0x20;  // RO 4 words

inline constexpr uint32_t kMaxLanes = 32;
// Bytes the register file spans (what the mmio backend maps).
inline constexpr uint32_t kSpanBytes = kLaneBase + kMaxLanes * kLaneStride;

inline constexpr uint32_t LaneReg(uint32_t lane, uint32_t reg) {
  return kLaneBase + lane * kLaneStride + reg;
}

}  // namespace riskplan::accel::regs

#endif  // RISKPLAN_ACCEL_SHIM_COMPONENT_REGS_H_
