#include "core/risk/risk_evaluator.h"

#include "core/base/check.h"
#include "core/base/hash_mix.h"

namespace riskplan {
namespace {

// Packs a kernel site into 64 bits, or returns false when a field does not fit
// (then the site bypasses the cache). Impact cells are offset by 2^17 so that
// sites just outside the map stay representable.
bool PackSite(const KernelSite& s, uint64_t* key) {
  constexpr int64_t kOffset = int64_t{1} << 17;
  const int64_t i = s.impact_i + kOffset;
  const int64_t j = s.impact_j + kOffset;
  if (s.height_bin < 0 || s.height_bin >= (1 << 14) || s.heading_bin < 0 ||
      s.heading_bin >= (1 << 12) || i < 0 || i >= (int64_t{1} << 18) || j < 0 ||
      j >= (int64_t{1} << 18)) {
    return false;
  }
  *key = (static_cast<uint64_t>(s.height_bin) << 48) |
         (static_cast<uint64_t>(s.heading_bin) << 36) | (static_cast<uint64_t>(i) << 18) |
         static_cast<uint64_t>(j);
  return true;
}

}  // namespace

CachingRiskEvaluator::CachingRiskEvaluator(int log2_entries)
    : entries_(size_t{1} << log2_entries), mask_((uint64_t{1} << log2_entries) - 1) {}

absl::Status CachingRiskEvaluator::EvaluateBatch(const RiskModel& model,
                                                 std::span<const Pose> configs,
                                                 std::span<ConfigurationRisk> out) {
  RISKPLAN_DCHECK(out.size() == configs.size());
  if (model_ != &model) {
    std::fill(entries_.begin(), entries_.end(), Entry{});
    model_ = &model;
  }
  for (size_t n = 0; n < configs.size(); ++n) {
    KernelSite site;
    if (!model.Locate(configs[n], &site)) {
      out[n] = ConfigurationRisk{};
      continue;
    }
    uint64_t key = 0;
    Entry* entry = nullptr;
    if (PackSite(site, &key)) {
      entry = &entries_[Mix64(key) & mask_];
      if (entry->key == key) {
        ++hits_;
        ConfigurationRisk& r = out[n];
        r.risk = entry->risk;
        r.impact_factor = entry->impact_factor;
        r.expected_shelter = entry->expected_shelter;
        r.casualty_probability = entry->casualty_probability;
        r.exposed_area_m2 = model.table().bin(site.height_bin).exposed_area_m2;
        r.height_bin = site.height_bin;
        r.heading_bin = site.heading_bin;
        r.defined = true;
        continue;
      }
    }
    double impact_factor = 0.0;
    double shelter = 0.0;
    model.Ewmm(model.table().kernel(site.height_bin, site.heading_bin), site.impact_i,
               site.impact_j, &impact_factor, &shelter);
    out[n] = model.FromSums(site, impact_factor, shelter);
    if (entry != nullptr) {
      *entry = Entry{key, out[n].impact_factor, out[n].expected_shelter,
                     out[n].casualty_probability, out[n].risk};
    }
  }
  evaluated_ += configs.size();
  return absl::OkStatus();
}

}  // namespace riskplan
