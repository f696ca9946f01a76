#include "accel/shim/device.h"
#include "core/base/check.h"

namespace riskplan::accel {

ModelDevice::ModelDevice(NumberFormat format, std::string device) {
  info_.backend = "model";
  info_.device = std::move(device);
  info_.firmware = "riskplan fixed-point model 1";
  info_.format = format;
  info_.lanes = 1;
  info_.max_kernel_side = 63;
}

absl::Status ModelDevice::Evaluate(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                                   std::span<const DeviceSite> sites, std::span<Accumulator> impact,
                                   std::span<Accumulator> shelter, uint64_t* cycles) {
  RISKPLAN_DCHECK(impact.size() == sites.size() && shelter.size() == sites.size());
  for (size_t n = 0; n < sites.size(); ++n) {
    const DeviceSite& s = sites[n];
    ModelEwmm(map, kernels.kernel(s.height_bin, s.heading_bin), s.impact_i, s.impact_j, &impact[n],
              &shelter[n]);
  }
  *cycles = 0;
  return absl::OkStatus();
}

}  // namespace riskplan::accel
