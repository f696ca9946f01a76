// CpuRiskKernel: the CPU workers' configuration-risk kernel. Its results are
// bit for bit those of RiskModel::Evaluate: the same EWMM lane order, the same
// operations, no fused multiply-add (docs/accel.md explains why we keep it
// that way). What makes it faster:
// - the kernel sites of a batch are located in one pass, without library
//   calls (floor as one instruction, fmod as an integer remainder where that
//   is exact), with the terrain cell of a configuration a few ahead
//   prefetched;
// - the EWMM runs two (AVX2) or four (AVX-512) windows of the same size
//   through one loop specialised for the kernel's width, so that their
//   dependency chains hide each other's latency;
// - windows are read from a PreparedMap (the layers on 2 MiB pages) when the
//   PreparedMapCache has room;
// - a batch of scattered windows large enough is visited in row-major order
//   of its impact cells, so that the map is streamed through the caches once
//   rather than fetched window by window (results land in the caller's
//   order); a smaller one prefetches the rows of the windows ahead;
// - an optional SiteCache answers repeated kernel sites without an EWMM;
// - the kernels' weights are read from 64-byte-aligned copies
//   (KernelWeightsCache) when one is given and has room.
// Without AVX2 it evaluates with RiskModel's own functions.
//
// With CpuKernelOptions::precision = kFloat32 it is instead the documented
// float32 path (accel/float_kernel.h): the same sites, EWMM sums in float32
// with fused multiply-add, p_cas with exp for pow; within 1e-5 relative of
// RiskModel::Evaluate (docs/risk-model.md bounds and measures the error), not
// bit for bit. It needs the KernelWeightsCache for its float32 weights;
// without one (or without room) it computes exactly.
//
// A kernel holds scratch buffers: one per thread (thread-compatible). The
// caches are shared, thread-safe, and must outlive the kernel.
#ifndef RISKPLAN_ACCEL_CPU_KERNEL_H_
#define RISKPLAN_ACCEL_CPU_KERNEL_H_

#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "accel/batch_locate.h"
#include "accel/kernel_weights.h"
#include "accel/prepared_map.h"
#include "accel/site_cache.h"
#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

namespace riskplan::accel {

class FastRiskFinisher;

// The instruction set of the kernel's loops; every choice gives the same bits.
enum class Isa { kAuto = -1, kPortable = 0, kAvx2 = 1, kAvx512 = 2 };

// Which results the kernel gives.
enum class KernelPrecision {
  kExact = 0,    // bit for bit RiskModel::Evaluate
  kFloat32 = 1,  // the float32 path: within 1e-5 relative of it
};
// "exact", "float32".
std::string_view KernelPrecisionName(KernelPrecision precision);
// Parses KernelPrecisionName()'s names; false for anything else.
bool ParseKernelPrecision(std::string_view name, KernelPrecision* precision);

struct CpuKernelOptions {
  KernelPrecision precision = KernelPrecision::kExact;
  // kAuto: the best the machine has (lower choices are for benchmarks/tests).
  Isa isa = Isa::kAuto;
  // Scattered batches of at least this many windows to compute are visited
  // in impact-cell order (0: never).
  int sort_min_configs = 2048;
  // Distance, in windows, of the software prefetch for scattered windows
  // (0: none).
  int prefetch_distance = 4;
};

struct CpuKernelStats {
  uint64_t configurations = 0;  // all, defined or not
  uint64_t cache_hits = 0;
  uint64_t repeats = 0;  // sites equal to the one before them, copied
  uint64_t ewmms = 0;    // windows computed
};

class CpuRiskKernel {
 public:
  // Any cache may be null (no prepared maps: the map's own layers are read;
  // no site cache: every window is computed; no weights cache: the table's
  // own weights, and the float32 path computes exactly).
  CpuRiskKernel(PreparedMapCache* maps, SiteCache* sites, CpuKernelOptions options = {},
                KernelWeightsCache* weights = nullptr);
  ~CpuRiskKernel();

  // out[i] = model.Evaluate(configs[i]) for every i: bit for bit with
  // kExact, within the float32 path's bound with kFloat32 (defined, bins and
  // exposed area always exactly).
  // REQUIRES: out.size() == configs.size() <= 2^32.
  void Evaluate(const RiskModel& model, std::span<const Pose> configs,
                std::span<ConfigurationRisk> out);

  // Steps 1-3 of the spec for a batch: appends the defined configurations'
  // sites to *sites and sets out[i] = ConfigurationRisk{} for the others.
  // Exactly RiskModel::Locate. Also used by the FPGA workers, which locate on
  // the server and send sites to the board.
  static void LocateBatch(const RiskModel& model, std::span<const Pose> configs,
                          std::span<ConfigurationRisk> out, std::vector<LocatedSite>* sites);

  // The EWMM sums of `sites` in their order, exactly RiskModel::Ewmm:
  // impact_factor[n] and expected_shelter[n] belong to sites[n].
  void Sums(const RiskModel& model, std::span<const LocatedSite> sites,
            std::span<double> impact_factor, std::span<double> expected_shelter);

  const CpuKernelStats& stats() const { return stats_; }
  Isa isa() const { return isa_; }
  KernelPrecision precision() const { return options_.precision; }
  // What kAuto resolves to on this machine.
  static Isa BestIsa();

 private:
  const float* DensityFor(const RiskModel& model, const float** shelter);
  // The aligned copy of the model's weights in `format`, or null.
  const KernelWeights* WeightsFor(const RiskModel& model, WeightFormat format);
  // The float32 path's sums (exact sums where it has no float32 weights).
  void SumsFloat32(const RiskModel& model, std::span<const LocatedSite> sites,
                   std::span<double> impact_factor, std::span<double> expected_shelter);

  PreparedMapCache* const maps_;
  SiteCache* const site_cache_;
  const CpuKernelOptions options_;
  const Isa isa_;
  CpuKernelStats stats_;
  // The prepared map of the last model seen, and the map it belongs to.
  std::weak_ptr<const RiskMap> last_map_;
  std::shared_ptr<const PreparedMap> last_prepared_;
  KernelWeightsCache* const weights_cache_;
  // The weights copy of the last table seen, per format.
  std::weak_ptr<const ImpactTable> last_table_[2];
  std::shared_ptr<const KernelWeights> last_weights_[2];
  std::unique_ptr<FastRiskFinisher> finisher_;
  // Scratch.
  std::vector<LocatedSite> sites_;
  std::vector<LocatedSite> ordered_;
  struct Repeat {
    uint32_t index;    // a configuration whose site equals the one before it
    uint32_t same_as;  // the configuration its result is copied from
  };
  std::vector<Repeat> repeats_;
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> counts_;
  std::vector<double> impact_;
  std::vector<double> shelter_;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_CPU_KERNEL_H_
