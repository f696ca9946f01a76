#include "accel/shim/component_model.h"

#include "accel/shim/component_regs.h"

namespace riskplan::accel {

ComponentModel::ComponentModel(const ComponentConfig& config)
    : config_(config),
      lanes_(config.lanes),
      weights_(static_cast<size_t>(config.weight_slots) * config.max_side * config.max_side) {}

uint32_t ComponentModel::Read32(uint32_t offset) {
  switch (offset) {
    case regs::kId:
      return regs::kIdValue;
    case regs::kVersion:
      return regs::kVersionValue;
    case regs::kCaps:
      return config_.lanes | uint32_t(config_.format.weight_frac_bits) << 8 |
             uint32_t(config_.format.cell_bits) << 16 | uint32_t(config_.format.acc_bits) << 24;
    case regs::kLimits:
      return config_.max_side | config_.weight_slots << 16;
    case regs::kStatus:
      return status_;
    case regs::kCutCols:
      return cut_cols_;
    case regs::kCutRows:
      return cut_rows_;
    case regs::kLaneMask:
      return lane_mask_;
    case regs::kCyclesLo:
      return static_cast<uint32_t>(cycles_);
    case regs::kCyclesHi:
      return static_cast<uint32_t>(cycles_ >> 32);
    case regs::kClockHz:
      return static_cast<uint32_t>(config_.clock_hz);
    case regs::kWaddr:
      return waddr_;
  }
  if (offset >= regs::kLaneBase && offset < regs::kLaneBase + config_.lanes * regs::kLaneStride) {
    const Lane& lane = lanes_[(offset - regs::kLaneBase) / regs::kLaneStride];
    const uint32_t reg = (offset - regs::kLaneBase) % regs::kLaneStride;
    uint32_t words[4];
    switch (reg) {
      case regs::kLaneSlot:
        return lane.slot;
      case regs::kLaneSide:
        return lane.side;
      case regs::kLaneCol:
        return lane.col;
      case regs::kLaneRow:
        return lane.row;
    }
    if (reg >= regs::kLaneImpact && reg < regs::kLaneImpact + 16) {
      AccumulatorToWords(lane.impact, words);
      return words[(reg - regs::kLaneImpact) / 4];
    }
    if (reg >= regs::kLaneShelter && reg < regs::kLaneShelter + 16) {
      AccumulatorToWords(lane.shelter, words);
      return words[(reg - regs::kLaneShelter) / 4];
    }
  }
  return 0;
}

void ComponentModel::Write32(uint32_t offset, uint32_t value) {
  switch (offset) {
    case regs::kCtrl:
      if (value & regs::kCtrlReset) {
        status_ = 0;
        cells_ = 0;
        words_.clear();
        for (Lane& lane : lanes_) lane = Lane{};
      }
      if (value & regs::kCtrlStart) Start();
      return;
    case regs::kCutCols:
      cut_cols_ = value;
      return;
    case regs::kCutRows:
      cut_rows_ = value;
      return;
    case regs::kLaneMask:
      lane_mask_ = value;
      return;
    case regs::kWaddr:
      waddr_ = value;
      return;
    case regs::kWdataLo:
      wdata_lo_ = value;
      return;
    case regs::kWdataHi: {
      const uint32_t slot = waddr_ >> 16;
      const uint32_t index = waddr_ & 0xffff;
      const size_t per_slot = static_cast<size_t>(config_.max_side) * config_.max_side;
      if (status_ & regs::kStatusBusy) {
        // Weights are loaded between jobs: in the RTL a write during a job
        // would race the lanes' reads (error 3, docs/rtl.md).
        Fail(regs::kErrorWeightBusy);
        return;
      }
      if (slot < config_.weight_slots && index < per_slot) {
        weights_[slot * per_slot + index] = uint64_t{value} << 32 | wdata_lo_;
      }
      // The index steps by itself: a kernel loads with one WADDR write, then
      // WDATA_LO and WDATA_HI per weight.
      waddr_ = (slot << 16) | ((index + 1) & 0xffff);
      return;
    }
    case regs::kStream: {
      if (!(status_ & regs::kStatusBusy)) {
        Fail(regs::kErrorStream);
        return;
      }
      words_.push_back(value);
      // A cell is its density then its shelter, each one 32-bit word when
      // M <= 32, else two (low word first), as the register map says.
      const size_t per_value = config_.format.cell_bits <= 32 ? 1 : 2;
      if (words_.size() == 2 * per_value) {
        const auto value_at = [&](size_t first) {
          return per_value == 1 ? uint64_t{words_[first]}
                                : (uint64_t{words_[first + 1]} << 32 | words_[first]);
        };
        AddCell(value_at(0), value_at(per_value));
        words_.clear();
      }
      return;
    }
  }
  if (offset >= regs::kLaneBase && offset < regs::kLaneBase + config_.lanes * regs::kLaneStride) {
    Lane& lane = lanes_[(offset - regs::kLaneBase) / regs::kLaneStride];
    switch ((offset - regs::kLaneBase) % regs::kLaneStride) {
      case regs::kLaneSlot:
        lane.slot = value;
        break;
      case regs::kLaneSide:
        lane.side = value;
        break;
      case regs::kLaneCol:
        lane.col = value;
        break;
      case regs::kLaneRow:
        lane.row = value;
        break;
    }
  }
}

void ComponentModel::Fail(uint32_t code) {
  status_ = regs::kStatusError | regs::kStatusDone | (code << 8);
}

// START's checks are the RTL's (docs/rtl.md, "Job control"): every lane in
// LANE_MASK exists, has its slot and side in range and its window inside the
// cut, and the cut is at most 65535 x 65535; any other job is refused with
// error 1 before a cell is taken.
void ComponentModel::Start() {
  for (Lane& lane : lanes_) {
    lane.impact = 0;
    lane.shelter = 0;
  }
  if (cut_cols_ > 0xffff || cut_rows_ > 0xffff) {
    Fail(regs::kErrorBadLane);
    return;
  }
  for (uint32_t l = 0; l < config_.lanes; ++l) {
    const Lane& lane = lanes_[l];
    if (!(lane_mask_ & (1u << l))) continue;
    if (lane.slot >= config_.weight_slots || lane.side == 0 || lane.side > config_.max_side ||
        uint64_t{lane.col} + lane.side > cut_cols_ || uint64_t{lane.row} + lane.side > cut_rows_) {
      Fail(regs::kErrorBadLane);
      return;
    }
  }
  if (lane_mask_ >> config_.lanes != 0) {
    Fail(regs::kErrorBadLane);
    return;
  }
  cells_ = 0;
  words_.clear();
  cycles_ = 0;
  status_ = regs::kStatusBusy;
  if (uint64_t{cut_cols_} * cut_rows_ == 0) status_ = regs::kStatusDone;
}

void ComponentModel::AddCell(uint64_t density, uint64_t shelter) {
  const uint32_t col = static_cast<uint32_t>(cells_ % cut_cols_);
  const uint32_t row = static_cast<uint32_t>(cells_ / cut_cols_);
  const size_t per_slot = static_cast<size_t>(config_.max_side) * config_.max_side;
  for (uint32_t l = 0; l < config_.lanes; ++l) {
    if (!(lane_mask_ & (1u << l))) continue;
    Lane& lane = lanes_[l];
    if (col < lane.col || col >= lane.col + lane.side || row < lane.row ||
        row >= lane.row + lane.side) {
      continue;
    }
    const uint64_t w =
        weights_[lane.slot * per_slot + (row - lane.row) * lane.side + (col - lane.col)];
    lane.impact += static_cast<Accumulator>(w) * density;
    lane.shelter += static_cast<Accumulator>(w) * shelter;
  }
  ++cycles_;  // one cut cell per clock
  if (++cells_ == uint64_t{cut_cols_} * cut_rows_) {
    cycles_ += kPipelineCycles;
    status_ = regs::kStatusDone;
  }
}

}  // namespace riskplan::accel
