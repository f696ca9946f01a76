// EwmmDevice: what riskplan-fpga-shim drives. A device computes, for a batch
// of kernel sites, the exact fixed-point EWMM sums of a quantised map and
// kernel table (accel/fixed_point.h); the server turns them into risks.
//
// Backends: ModelDevice (the datapath in software, bit-exact) and MmioDevice
// (the component's registers: on a DE10-Nano through /dev/mem or UIO, on the
// in-memory ComponentModel, or on the RTL under Verilator, accel/rtl/).
//
// Thread-compatible: the shim serialises calls.
#ifndef RISKPLAN_ACCEL_SHIM_DEVICE_H_
#define RISKPLAN_ACCEL_SHIM_DEVICE_H_

#include <cstdint>
#include <span>
#include <string>

#include "absl/status/status.h"
#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel/shim_protocol.h"

namespace riskplan::accel {

struct DeviceInfo {
  std::string backend;   // "model", "mmio", ...
  std::string device;    // instance identity
  std::string firmware;  // component version or model revision
  NumberFormat format;
  uint32_t lanes = 1;
  uint32_t max_kernel_side = 63;
  uint64_t clock_hz = 0;
};

class EwmmDevice {
 public:
  virtual ~EwmmDevice() = default;

  virtual const DeviceInfo& info() const = 0;

  // impact[n], shelter[n] = the raw sums of the window of kernel
  // (b, k) = (sites[n].height_bin, sites[n].heading_bin) centred on
  // (impact_i, impact_j). Sites are valid for `kernels` (checked by the
  // caller); windows may reach past the map (out-of-map cells read the
  // quantised 0 and 10). *cycles gets the device cycles spent (0 if unknown).
  virtual absl::Status Evaluate(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                                std::span<const DeviceSite> sites, std::span<Accumulator> impact,
                                std::span<Accumulator> shelter, uint64_t* cycles) = 0;
};

// The fixed-point datapath in software: ModelEwmm per site, one lane.
class ModelDevice final : public EwmmDevice {
 public:
  explicit ModelDevice(NumberFormat format, std::string device = "model-0");
  const DeviceInfo& info() const override { return info_; }
  absl::Status Evaluate(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                        std::span<const DeviceSite> sites, std::span<Accumulator> impact,
                        std::span<Accumulator> shelter, uint64_t* cycles) override;

 private:
  DeviceInfo info_;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_DEVICE_H_
