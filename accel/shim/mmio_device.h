// MmioDevice: drives the streaming EWMM component through its registers
// (component_regs.h) on any RegisterBus: /dev/mem or UIO on a DE10-Nano,
// the in-memory ComponentModel, or (issue 6) a Verilator model.
//
// A batch of sites is cut into jobs: sites are taken in order while the job
// has a free lane, its cut (the bounding box of the lanes' windows) stays
// within max_cut_cells and its kernels fit the weight slots. Kernels stay in their slots between
// jobs (least recently used slot replaced), so neighbouring samples of a trajectory, which share
// their kernel and most of their window (the thesis measured more than 90 % overlap), cost one cut
// streamed once for up to `lanes` risks. No zeroing: a lane reads only its own side x side weights.
//
// What runs only on a board: MappedRegisterBus on /dev/mem or /dev/uioN with
// the component loaded in the FPGA. Everything else (job planning, kernel
// slots, streaming, result reading, error and timeout handling) runs against
// the ComponentModel in tests.
//
// Thread-compatible (the shim serialises device access).
#ifndef RISKPLAN_ACCEL_SHIM_MMIO_DEVICE_H_
#define RISKPLAN_ACCEL_SHIM_MMIO_DEVICE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "accel/shim/device.h"
#include "accel/shim/register_bus.h"

namespace riskplan::accel {

struct MmioOptions {
  uint32_t max_cut_cells = 4096;
  // Use at most this many of the component's lanes (0: all); for measuring
  // cycles by lane count.
  uint32_t max_lanes = 0;
  // DeviceInfo::backend ("mmio"; "verilator" for the RTL under simulation).
  std::string backend = "mmio";
  // How long a job may take before the device is declared failed.
  absl::Duration job_timeout = absl::Seconds(1);
};

class MmioDevice final : public EwmmDevice {
 public:
  // Resets the component and reads its identity and capabilities.
  // FailedPrecondition when the bus does not show the component's ID.
  static absl::StatusOr<std::unique_ptr<MmioDevice>> Open(std::unique_ptr<RegisterBus> bus,
                                                          const MmioOptions& options);

  const DeviceInfo& info() const override { return info_; }
  absl::Status Evaluate(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                        std::span<const DeviceSite> sites, std::span<Accumulator> impact,
                        std::span<Accumulator> shelter, uint64_t* cycles) override;

  // Jobs run and kernel uploads since Open (for tests and statistics).
  uint64_t jobs() const { return jobs_; }
  uint64_t kernel_uploads() const { return kernel_uploads_; }

 private:
  struct Slot {
    uint64_t table_id = 0;  // QuantizedKernelTable::id; 0: empty
    int height_bin = 0, heading_bin = 0;
    uint64_t last_use = 0;
  };
  MmioDevice(std::unique_ptr<RegisterBus> bus, const MmioOptions& options)
      : bus_(std::move(bus)), options_(options) {}

  // Runs one job over sites[order[first..last)).
  absl::Status RunJob(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                      std::span<const DeviceSite> sites, std::span<const uint32_t> job,
                      std::span<Accumulator> impact, std::span<Accumulator> shelter,
                      uint64_t* cycles);
  // The slot holding kernel (b, k), loading it if needed; never one of `busy`.
  uint32_t SlotFor(const QuantizedKernelTable& kernels, int b, int k,
                   const std::vector<uint32_t>& busy);
  void StreamValue(uint64_t value);
  std::vector<uint32_t> stream_;  // the words of the cut being streamed

  std::unique_ptr<RegisterBus> bus_;
  const MmioOptions options_;
  DeviceInfo info_;
  uint32_t slots_count_ = 0;
  std::vector<Slot> slots_;
  uint64_t clock_ = 0;  // slot LRU clock
  uint64_t jobs_ = 0;
  uint64_t kernel_uploads_ = 0;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_MMIO_DEVICE_H_
