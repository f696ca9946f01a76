#include "core/risk/impact_table.h"

#include <cmath>
#include <string>

#include "absl/strings/str_format.h"
#include "core/base/geometry.h"
#include "core/base/wind.h"

namespace riskplan {

double CasualtyProbability(double energy_j, double expected_shelter, double alpha_j,
                           double beta_j) {
  if (!(energy_j > beta_j)) return 0.0;
  if (!(expected_shelter > 0.0)) return 1.0;
  const double e = std::pow(beta_j / energy_j, 3.0 / expected_shelter);
  const double k = std::min(1.0, e);
  return (1.0 - k) / (1.0 - 2.0 * k + std::sqrt(alpha_j / beta_j) * e);
}

double ExposedArea(double impact_angle_rad, const ModelParams& p) {
  const double r = p.person_radius_m + p.uav_radius_m;
  return 2.0 * r * p.person_height_m / std::tan(impact_angle_rad) + kPi * r * r;
}

namespace {

absl::Status CheckResolution(double res_m) {
  if (!std::isfinite(res_m) || res_m <= 0.0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("impact table: cell size %g m must be finite and > 0", res_m));
  }
  return absl::OkStatus();
}

// Everything of the height bins but the kernels' weights: the falls (one
// integration for all of them), dispersions, half-widths and exposed areas.
absl::StatusOr<std::vector<HeightBin>> MakeHeightBins(const ModelParams& params, double res_m,
                                                      const StopCondition& stop) {
  const int n_bins = params.HeightBins();
  std::vector<double> heights(n_bins);
  for (int b = 1; b <= n_bins; ++b) heights[b - 1] = b * params.height_bin_m;
  absl::StatusOr<std::vector<BallisticImpact>> falls =
      SimulateBallisticFalls(heights, params, stop);
  if (!falls.ok()) return falls.status();
  std::vector<HeightBin> bins(n_bins);
  for (int b = 1; b <= n_bins; ++b) {
    HeightBin& hb = bins[b - 1];
    hb.height_m = heights[b - 1];
    hb.fall = (*falls)[b - 1];
    const double t = hb.fall.fall_time_s;
    const double sp = params.sigma_pos_m;
    const double ss = t * params.sigma_speed_mps;
    const double sw = t * params.sigma_wind_mps;
    hb.sigma_along_m = std::sqrt(sp * sp + ss * ss + sw * sw);
    hb.sigma_across_m = std::sqrt(sp * sp + sw * sw);
    const double reach = 3.0 * std::max(hb.sigma_along_m, hb.sigma_across_m) / res_m;
    hb.half_width = static_cast<int>(std::min<double>(std::ceil(reach), params.max_half_width));
    hb.exposed_area_m2 = ExposedArea(hb.fall.angle_rad, params);
    // Every number a risk is made of must be finite: parameters at the edge
    // of their ranges are refused here rather than answered with NaN.
    if (!std::isfinite(hb.fall.energy_j) || !std::isfinite(hb.fall.distance_m) ||
        !std::isfinite(hb.exposed_area_m2) || !(hb.sigma_across_m > 0.0) ||
        !std::isfinite(hb.sigma_along_m)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "impact table: at height %g m the parameters give impact energy %g J, distance %g m, "
          "exposed area %g m^2 and dispersion %g x %g m; each must be finite",
          hb.height_m, hb.fall.energy_j, hb.fall.distance_m, hb.exposed_area_m2, hb.sigma_along_m,
          hb.sigma_across_m));
    }
  }
  return bins;
}

// Weights of one heading's kernel at a half-width: Side() x Stride().
int64_t KernelWeights(int half_width) {
  ImpactKernel shape;
  shape.half_width = half_width;
  return static_cast<int64_t>(shape.Side()) * shape.Stride();
}

// MemoryBytes() of a table with these bins, counted in double so that no
// parameter set can overflow it.
double TableBytes(const std::vector<HeightBin>& bins, int heading_bins, size_t table_object) {
  double weights = 0.0;
  for (const HeightBin& hb : bins) {
    weights += static_cast<double>(KernelWeights(hb.half_width)) * heading_bins;
  }
  return static_cast<double>(table_object) + static_cast<double>(bins.size()) * sizeof(HeightBin) +
         static_cast<double>(bins.size()) * heading_bins * sizeof(ImpactKernel) +
         weights * sizeof(double);
}

absl::Status CheckTableBytes(double bytes, bool at_least, const ModelParams& params,
                             const ModelBuildLimits& limits) {
  if (bytes <= static_cast<double>(limits.max_table_bytes)) return absl::OkStatus();
  const int hw = params.max_half_width;
  return absl::InvalidArgumentError(absl::StrFormat(
      "the impact table of 'heading_bins' %d x %d height bins ('table_max_height_m' %g / "
      "'height_bin_m' %g), kernels of up to %d x %d weights ('max_half_width' %d), needs %s%.0f "
      "bytes; the limit is %d bytes%s",
      params.heading_bins, params.HeightBins(), params.table_max_height_m, params.height_bin_m,
      2 * hw + 1, KernelWeights(hw) / (2 * hw + 1), hw, at_least ? "at least " : "", bytes,
      limits.max_table_bytes,
      limits.max_table_bytes_source.empty()
          ? std::string()
          : absl::StrFormat(" (%s)", std::string(limits.max_table_bytes_source))));
}

// The wind-dependent numbers of kernel (b, k) (spec version 3, section 2):
// its offset, impact energy and angle over the ground, and exposed area. In
// still air they are the height bin's own (version 2), copied bit for bit.
absl::Status SetKernelFall(const HeightBin& hb, int k, int n_head, const ModelParams& params,
                           const WindVector& w, ImpactKernel* kernel) {
  const double theta = k * kTwoPi / n_head;
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  const double d = hb.fall.distance_m;
  if (params.Calm()) {
    kernel->offset_x_m = d * c;
    kernel->offset_y_m = d * s;
    kernel->energy_j = hb.fall.energy_j;
    kernel->impact_angle_rad = hb.fall.angle_rad;
    kernel->exposed_area_m2 = hb.exposed_area_m2;
    return absl::OkStatus();
  }
  const double t = hb.fall.fall_time_s;
  const double vh = hb.fall.v_horizontal_mps;
  const double vz = hb.fall.v_vertical_mps;
  const double wind = params.wind_speed_mps;
  kernel->offset_x_m = d * c + w.x * t;
  kernel->offset_y_m = d * s + w.y * t;
  // |v_h u_k + w|^2, written as the spec writes it.
  const double ground2 = vh * vh + 2.0 * vh * (w.x * c + w.y * s) + wind * wind;
  kernel->energy_j = 0.5 * params.mass_kg * (ground2 + vz * vz);
  kernel->impact_angle_rad = std::atan2(std::fabs(vz), std::sqrt(std::max(0.0, ground2)));
  kernel->exposed_area_m2 = ExposedArea(kernel->impact_angle_rad, params);
  if (!std::isfinite(kernel->energy_j) || !std::isfinite(kernel->exposed_area_m2) ||
      !std::isfinite(kernel->offset_x_m) || !std::isfinite(kernel->offset_y_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "impact table: at height %g m, air heading bin %d, the wind of %g m/s from %g degrees "
        "gives impact energy %g J and exposed area %g m^2; each must be finite",
        hb.height_m, k, params.wind_speed_mps, params.wind_from_deg, kernel->energy_j,
        kernel->exposed_area_m2));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::shared_ptr<const ImpactTable>> ImpactTable::InWind(const ImpactTable& base,
                                                                       const ModelParams& params) {
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  if (!SameKernelParams(base.params_, params)) {
    return absl::InvalidArgumentError(
        "impact table: a table in another wind can be made only from one of the same kernel "
        "parameters");
  }
  auto table = std::shared_ptr<ImpactTable>(new ImpactTable());
  table->params_ = params;
  table->res_m_ = base.res_m_;
  table->heading_bins_ = base.heading_bins_;
  table->bins_ = base.bins_;
  table->kernels_ = base.kernels_;  // the weights pointers stay valid: weights_ is shared
  table->weights_ = base.weights_;
  const WindVector w = WindVectorOf(params.wind_speed_mps, params.wind_from_deg);
  const int n_head = table->heading_bins_;
  for (int b = 1; b <= table->height_bins(); ++b) {
    for (int k = 0; k < n_head; ++k) {
      if (absl::Status s = SetKernelFall(table->bins_[b - 1], k, n_head, params, w,
                                         &table->kernels_[static_cast<size_t>(b - 1) * n_head + k]);
          !s.ok()) {
        return s;
      }
    }
  }
  return std::shared_ptr<const ImpactTable>(std::move(table));
}

double ImpactTable::MinBytes(const ModelParams& params) {
  // TableBytes with a half-width of 0 for every bin: one row of
  // kKernelLanes weights per kernel.
  const double bins = params.HeightBins();
  const double kernels = bins * params.heading_bins;
  return static_cast<double>(sizeof(ImpactTable)) + bins * sizeof(HeightBin) +
         kernels * sizeof(ImpactKernel) + kernels * KernelWeights(0) * sizeof(double);
}

absl::Status ImpactTable::CheckMinBytes(const ModelParams& params, const ModelBuildLimits& limits) {
  return CheckTableBytes(MinBytes(params), /*at_least=*/true, params, limits);
}

absl::StatusOr<double> ImpactTable::ProjectedBytes(const ModelParams& params, double res_m,
                                                   const StopCondition& stop) {
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  if (absl::Status s = CheckResolution(res_m); !s.ok()) return s;
  absl::StatusOr<std::vector<HeightBin>> bins = MakeHeightBins(params, res_m, stop);
  if (!bins.ok()) return bins.status();
  return TableBytes(*bins, params.heading_bins, sizeof(ImpactTable));
}

absl::StatusOr<std::shared_ptr<const ImpactTable>> ImpactTable::Build(
    const ModelParams& params, double res_m, const ModelBuildLimits& limits) {
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  if (absl::Status s = CheckResolution(res_m); !s.ok()) return s;
  // Sizes first, cheapest bound first: nothing is integrated for a table
  // that cannot fit whatever its kernels, nothing allocated for one that
  // does not fit once they are known.
  if (absl::Status s = CheckMinBytes(params, limits); !s.ok()) return s;
  absl::StatusOr<std::vector<HeightBin>> bins = MakeHeightBins(params, res_m, limits.stop);
  if (!bins.ok()) return bins.status();
  if (absl::Status s = CheckTableBytes(TableBytes(*bins, params.heading_bins, sizeof(ImpactTable)),
                                       /*at_least=*/false, params, limits);
      !s.ok()) {
    return s;
  }

  auto table = std::shared_ptr<ImpactTable>(new ImpactTable());
  table->params_ = params;
  table->res_m_ = res_m;
  table->heading_bins_ = params.heading_bins;
  table->bins_ = *std::move(bins);
  const int n_bins = params.HeightBins();
  const int n_head = params.heading_bins;
  size_t total_weights = 0;
  for (const HeightBin& hb : table->bins_) {
    total_weights += static_cast<size_t>(KernelWeights(hb.half_width)) * n_head;
  }

  auto weights = std::make_shared<std::vector<double>>(total_weights);
  table->kernels_.resize(static_cast<size_t>(n_bins) * n_head);
  const WindVector wind = WindVectorOf(params.wind_speed_mps, params.wind_from_deg);
  size_t cursor = 0;
  for (int b = 1; b <= n_bins; ++b) {
    if (limits.stop.Reached()) return absl::CancelledError("impact table: stopped");
    const HeightBin& hb = table->bins_[b - 1];
    const int hw = hb.half_width;
    ImpactKernel shape;
    shape.half_width = hw;
    const int side = shape.Side();
    const int stride = shape.Stride();
    const double inv_a2 = 1.0 / (hb.sigma_along_m * hb.sigma_along_m);
    const double inv_c2 = 1.0 / (hb.sigma_across_m * hb.sigma_across_m);
    for (int k = 0; k < n_head; ++k) {
      const double theta = k * kTwoPi / n_head;
      const double c = std::cos(theta);
      const double s = std::sin(theta);
      double* w = &(*weights)[cursor];
      double sum = 0.0;
      for (int v = -hw; v <= hw; ++v) {
        for (int u = -hw; u <= hw; ++u) {
          const double ox = u * res_m;
          const double oy = v * res_m;
          // Offset in the frame of the heading: along it, and across it.
          const double along = c * ox + s * oy;
          const double across = -s * ox + c * oy;
          // The Gaussian's constant factor cancels in the normalisation below.
          const double value = std::exp(-0.5 * (along * along * inv_a2 + across * across * inv_c2));
          w[(v + hw) * stride + (u + hw)] = value;
          sum += value;
        }
      }
      // The centre weight is exp(0) = 1, so the sum is at least 1 unless a
      // dispersion is so small that its inverse square overflowed.
      if (!(sum >= 1.0) || !std::isfinite(sum)) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "impact table: the kernel at height %g m, heading bin %d sums to %g; the dispersion "
            "(%g x %g m) is too small for cells of %g m",
            hb.height_m, k, sum, hb.sigma_along_m, hb.sigma_across_m, res_m));
      }
      // Padding entries stay exactly 0 (the vector is value-initialised).
      for (int i = 0; i < side * stride; ++i) w[i] /= sum;
      ImpactKernel& kernel = table->kernels_[static_cast<size_t>(b - 1) * n_head + k];
      kernel.half_width = hw;
      if (absl::Status st = SetKernelFall(hb, k, n_head, params, wind, &kernel); !st.ok()) {
        return st;
      }
      kernel.weights = w;
      cursor += static_cast<size_t>(side) * stride;
    }
  }
  table->weights_ = std::move(weights);
  return std::shared_ptr<const ImpactTable>(std::move(table));
}

int ImpactTable::HeightBinOf(double height_m) const {
  const double b = std::floor(height_m / params_.height_bin_m + 0.5);
  if (!(b >= 1.0)) return 1;
  if (b > height_bins()) return height_bins();
  return static_cast<int>(b);
}

int ImpactTable::HeadingBinOf(double theta) const {
  const double bin_width = kTwoPi / heading_bins_;
  const double k = std::floor(theta / bin_width + 0.5);
  const double m = std::fmod(k, static_cast<double>(heading_bins_));
  return static_cast<int>(m < 0.0 ? m + heading_bins_ : m);
}

size_t ImpactTable::MemoryBytes() const {
  return sizeof(*this) + bins_.capacity() * sizeof(HeightBin) +
         kernels_.capacity() * sizeof(ImpactKernel) + WeightBytes();
}

}  // namespace riskplan
