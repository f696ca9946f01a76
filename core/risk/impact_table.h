// The impact table (spec section 2): for every height bin and heading bin, the
// ballistic impact (distance, energy, angle), the exposed area, and the
// normalised Gaussian impact kernel over map cells. These are the thesis's
// "precomputed probability matrices".
//
// A table depends on the model parameters (those compared by
// SameImpactTableParams) and on the map's cell size. It is immutable after
// Build() and safe to share between threads.
#ifndef RISKPLAN_CORE_RISK_IMPACT_TABLE_H_
#define RISKPLAN_CORE_RISK_IMPACT_TABLE_H_

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/check.h"
#include "core/base/model_params.h"
#include "core/risk/ballistic.h"

namespace riskplan {

// Everything the risk model needs about one height bin.
struct HeightBin {
  double height_m = 0.0;         // h_b = b * Delta h
  BallisticImpact fall;          // d, t_f, v_h, v_z, E, gamma at h_b
  double sigma_along_m = 0.0;    // sigma_a
  double sigma_across_m = 0.0;   // sigma_c
  int half_width = 0;            // hw (kernel is (2hw+1)^2 cells)
  double exposed_area_m2 = 0.0;  // A_exp
};

// One (height bin, heading bin) kernel. Weights are row-major with rows running
// north: weight of offset (u, v) is weights[(v + hw) * Stride() + (u + hw)].
// Each row is padded with zero weights to a multiple of kKernelLanes entries so
// that the EWMM loop runs in whole vectors.
inline constexpr int kKernelLanes = 8;

struct ImpactKernel {
  int half_width = 0;
  // Entries per stored row: Side() rounded up to a multiple of kKernelLanes.
  int Stride() const { return (Side() + kKernelLanes - 1) / kKernelLanes * kKernelLanes; }
  // o(b, k) = d(h_b) u_k + w t_f(h_b) (spec version 3, section 2): where the
  // fall carried by the air mass lands, from the failure's position.
  double offset_x_m = 0.0;
  double offset_y_m = 0.0;
  // Energy and angle of the impact over the ground, and the exposed area of
  // that angle (section 3 step 5). In still air the height bin's own.
  double energy_j = 0.0;
  double impact_angle_rad = 0.0;
  double exposed_area_m2 = 0.0;
  const double* weights = nullptr;
  int Side() const { return 2 * half_width + 1; }
};

// What building a risk model (its impact table, and a glide layer of its
// own) may use: a bound on the table's bytes, checked before anything is
// allocated, and a stop condition polled by the long loops (the ballistic
// integration, the kernels, the glide layer).
inline constexpr size_t kDefaultMaxTableBytes = size_t{512} << 20;
struct ModelBuildLimits {
  size_t max_table_bytes = kDefaultMaxTableBytes;
  // Appended to the message of a table refused for its size, e.g.
  // "--max_table_bytes": where the limit comes from.
  std::string_view max_table_bytes_source;
  StopCondition stop;
};

class ImpactTable {
 public:
  // Builds the table for `params` (which must pass ValidateModelParams) and
  // cells of side `res_m`. Its bytes (MemoryBytes) are computed first, and a
  // table of more than limits.max_table_bytes is refused before anything is
  // allocated: InvalidArgument naming the parameters that size it, the bytes
  // and the limit. Also InvalidArgument (naming the parameters) when the
  // ballistic fall does not end within kMaxFallTimeS or a number of the table
  // would not be finite; Cancelled when limits.stop is reached.
  static absl::StatusOr<std::shared_ptr<const ImpactTable>> Build(
      const ModelParams& params, double res_m, const ModelBuildLimits& limits = {});

  // The table for `params` built from `base`, a table of the same kernel
  // parameters (SameKernelParams) in another wind: the falls, dispersions and
  // kernel weights do not depend on the wind, so they are shared with `base`
  // (kept alive by the new table), and only each kernel's offset, energy,
  // angle and exposed area are computed again: a few thousand numbers, not
  // megabytes of weights. The result equals Build(params, base.res_m()) bit
  // for bit. InvalidArgument when the kernel parameters differ or a number
  // would not be finite. REQUIRES: ValidateModelParams(params).
  static absl::StatusOr<std::shared_ptr<const ImpactTable>> InWind(const ImpactTable& base,
                                                                   const ModelParams& params);

  // The bytes Build would allocate (exactly MemoryBytes() of the table),
  // computed from the parameters and one ballistic integration, without
  // building the kernels. Errors as Build's.
  static absl::StatusOr<double> ProjectedBytes(const ModelParams& params, double res_m,
                                               const StopCondition& stop = {});
  // A lower bound of ProjectedBytes that needs no integration (every kernel
  // is at least one row of kKernelLanes weights), cheap enough to refuse a
  // huge table on a request's own thread. REQUIRES: ValidateModelParams.
  static double MinBytes(const ModelParams& params);
  // InvalidArgument (Build's message) when MinBytes(params) exceeds
  // limits.max_table_bytes. REQUIRES: ValidateModelParams.
  static absl::Status CheckMinBytes(const ModelParams& params, const ModelBuildLimits& limits);

  const ModelParams& params() const { return params_; }
  double res_m() const { return res_m_; }
  int height_bins() const { return static_cast<int>(bins_.size()); }
  int heading_bins() const { return heading_bins_; }

  // Spec section 3 step 2. height_bin in [1, height_bins()].
  int HeightBinOf(double height_m) const;
  // round(theta / (2 pi / N_theta)) mod N_theta, for any finite theta.
  int HeadingBinOf(double theta) const;

  // REQUIRES: 1 <= b <= height_bins(), 0 <= k < heading_bins().
  const HeightBin& bin(int b) const {
    RISKPLAN_DCHECK(b >= 1 && b <= height_bins());
    return bins_[b - 1];
  }
  const ImpactKernel& kernel(int b, int k) const {
    RISKPLAN_DCHECK(b >= 1 && b <= height_bins() && k >= 0 && k < heading_bins());
    return kernels_[static_cast<size_t>(b - 1) * heading_bins_ + k];
  }

  // Bytes of the table, its kernel weights included even when they are shared
  // with another table (InWind).
  size_t MemoryBytes() const;
  // Bytes of the kernel weights alone (shared between the tables InWind
  // makes from one another).
  size_t WeightBytes() const { return weights_->capacity() * sizeof(double); }

 private:
  ImpactTable() = default;

  ModelParams params_;
  double res_m_ = 0.0;
  int heading_bins_ = 0;
  std::vector<HeightBin> bins_;
  std::vector<ImpactKernel> kernels_;
  // Storage behind every kernel's weights, shared by the tables of one set of
  // kernel parameters in different winds.
  std::shared_ptr<const std::vector<double>> weights_;
};

// Casualty probability of spec section 3 step 6, with the spec's limits:
// S = 0 gives 1 when E > beta else 0; E <= beta gives 0.
double CasualtyProbability(double energy_j, double expected_shelter, double alpha_j, double beta_j);

// Exposed area of spec section 3 step 5.
double ExposedArea(double impact_angle_rad, const ModelParams& params);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_IMPACT_TABLE_H_
