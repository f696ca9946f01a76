// The RTL of the streaming EWMM component (accel/rtl/rp_ewmm.sv), compiled
// by Verilator, as a RegisterBus: riskplan-fpga-shim's `verilator` backend
// drives it through the same registers as a board (MmioDevice), cycle by
// cycle, and streams cuts through its Avalon-ST sink at one cell per clock,
// as a DMA on the board would.
//
// Every bus access is simulated clock by clock: a CSR read or write takes
// one clock (read latency 1, no wait states), a cell of the stream one clock
// while the sink is ready. cycles() counts all of them; the component's own
// CYCLES register counts START to DONE of a job.
//
// Configurations are fixed when the RTL is verilated (parameters of
// rp_ewmm); VerilatedConfigs() lists those built into this binary.
//
// Not thread-safe (the shim serialises device access). Built only with
// RISKPLAN_WITH_VERILATOR (on when CMake finds Verilator).
#ifndef RISKPLAN_ACCEL_RTL_VERILATED_COMPONENT_H_
#define RISKPLAN_ACCEL_RTL_VERILATED_COMPONENT_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "accel/fixed_point.h"
#include "accel/shim/register_bus.h"

namespace riskplan::accel {

struct RtlConfig {
  std::string name;  // "l8-board"
  uint32_t lanes = 0;
  NumberFormat format;
  uint32_t weight_slots = 0;
  uint32_t max_side = 0;
  uint64_t clock_hz = 0;
  std::string description;
};

// The configurations verilated into this binary; the first is the default.
const std::vector<RtlConfig>& VerilatedConfigs();

class SimulatedComponentBus : public RegisterBus {
 public:
  // Clock cycles simulated since the model was created (bus accesses,
  // stream beats, stalls and the reset).
  virtual uint64_t cycles() const = 0;
  virtual const RtlConfig& config() const = 0;
};

// A fresh model of `config` (a name from VerilatedConfigs()), held in reset
// for two clocks. NotFound lists the configurations there are.
absl::StatusOr<std::unique_ptr<SimulatedComponentBus>> OpenVerilatedComponent(
    absl::string_view config);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_RTL_VERILATED_COMPONENT_H_
