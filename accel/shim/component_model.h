// ComponentModel: the streaming EWMM component of docs/accel.md as an
// in-memory RegisterBus: the behaviour the RTL of issue 6 must have, at the
// register level. It lets the mmio backend run, and be tested, without a
// board (riskplan-fpga-shim --device=mmio --mmio_device=model).
//
// Cycle count of a job (the CYCLES register): one cut cell per clock through
// the stream (density and shelter side by side) plus kPipelineCycles to drain
// the lanes' pipeline, which is what the RTL (accel/rtl/rp_ewmm.sv) takes when
// its stream sink is fed a cell every clock (tests/rtl/rtl_component_test.cc
// checks the two agree); 0 for an empty cut. Kernel writes are not counted
// (they go through the CSR slave, between jobs).
//
// Not thread-safe (the shim serialises device access).
#ifndef RISKPLAN_ACCEL_SHIM_COMPONENT_MODEL_H_
#define RISKPLAN_ACCEL_SHIM_COMPONENT_MODEL_H_

#include <cstdint>
#include <string>
#include <vector>

#include "accel/fixed_point.h"
#include "accel/shim/register_bus.h"

namespace riskplan::accel {

struct ComponentConfig {
  NumberFormat format = NumberFormat::Board();
  uint32_t lanes = 8;  // <= regs::kMaxLanes
  uint32_t weight_slots = 8;
  uint32_t max_side = 63;  // kernel side; a slot holds max_side^2 weights
  uint64_t clock_hz = 100'000'000;
};

class ComponentModel final : public RegisterBus {
 public:
  static constexpr uint64_t kPipelineCycles = 2;

  explicit ComponentModel(const ComponentConfig& config);

  uint32_t Read32(uint32_t offset) override;
  void Write32(uint32_t offset, uint32_t value) override;
  std::string Name() const override { return "component-model"; }

 private:
  struct Lane {
    uint32_t slot = 0, side = 0, col = 0, row = 0;
    Accumulator impact = 0, shelter = 0;
  };

  void Start();
  void AddCell(uint64_t density, uint64_t shelter);
  void Fail(uint32_t code);

  const ComponentConfig config_;
  std::vector<Lane> lanes_;
  std::vector<uint64_t> weights_;  // slots x max_side^2
  uint32_t cut_cols_ = 0, cut_rows_ = 0, lane_mask_ = 0;
  uint32_t status_ = 0;
  uint64_t cycles_ = 0;
  uint32_t waddr_ = 0;
  uint32_t wdata_lo_ = 0;
  // Stream state: cells received, and the words of the cell in progress.
  uint64_t cells_ = 0;
  std::vector<uint32_t> words_;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_COMPONENT_MODEL_H_
