// Steps 1-3 of the spec (locating: terrain, bins, impact cell) and the window
// rule of step 4 for a batch of configurations, exactly RiskModel::Locate for
// each: the CPU kernel's first stage, and what the FPGA workers send to a
// board (sites). A configuration whose impact window reaches past the map
// gets no site, so no kernel, board or RTL ever computes sums for it from
// padding: its M stays undefined (spec version 2).
#ifndef RISKPLAN_ACCEL_BATCH_LOCATE_H_
#define RISKPLAN_ACCEL_BATCH_LOCATE_H_

#include <cstdint>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

namespace riskplan::accel {

// A located configuration: its kernel site and its index in the batch.
struct LocatedSite {
  KernelSite site;
  uint32_t index = 0;
};

// Appends the sites of the defined configurations of `configs`, in order, to
// *sites (index = position in configs) and sets out[i] = ConfigurationRisk{}
// for the others. The same results bit for bit as RiskModel::Locate, with
// `use_avx2` (REQUIRES: the CPU has AVX2) or without.
// REQUIRES: out.size() == configs.size() <= 2^32.
void LocateSites(const RiskModel& model, std::span<const Pose> configs,
                 std::span<ConfigurationRisk> out, std::vector<LocatedSite>* sites, bool use_avx2);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_BATCH_LOCATE_H_
