#include "core/risk/impact_table.h"

#include <cmath>

#include "absl/strings/str_format.h"
#include "core/base/geometry.h"

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

absl::StatusOr<std::shared_ptr<const ImpactTable>> ImpactTable::Build(const ModelParams& params,
                                                                      double res_m) {
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  if (!std::isfinite(res_m) || res_m <= 0.0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("impact table: cell size %g m must be finite and > 0", res_m));
  }
  auto table = std::shared_ptr<ImpactTable>(new ImpactTable());
  table->params_ = params;
  table->res_m_ = res_m;
  table->heading_bins_ = params.heading_bins;

  const int n_bins = params.HeightBins();
  const int n_head = params.heading_bins;
  table->bins_.resize(n_bins);
  size_t total_weights = 0;
  for (int b = 1; b <= n_bins; ++b) {
    HeightBin& hb = table->bins_[b - 1];
    hb.height_m = b * params.height_bin_m;
    hb.fall = SimulateBallisticFall(hb.height_m, params);
    const double t = hb.fall.fall_time_s;
    const double sp = params.sigma_pos_m;
    const double ss = t * params.sigma_speed_mps;
    const double sw = t * params.sigma_wind_mps;
    hb.sigma_along_m = std::sqrt(sp * sp + ss * ss + sw * sw);
    hb.sigma_across_m = std::sqrt(sp * sp + sw * sw);
    const double reach = 3.0 * std::max(hb.sigma_along_m, hb.sigma_across_m) / res_m;
    hb.half_width = static_cast<int>(std::min<double>(std::ceil(reach), params.max_half_width));
    hb.exposed_area_m2 = ExposedArea(hb.fall.angle_rad, params);
    ImpactKernel shape;
    shape.half_width = hb.half_width;
    total_weights += static_cast<size_t>(shape.Side()) * shape.Stride() * n_head;
  }

  table->weights_.resize(total_weights);
  table->kernels_.resize(static_cast<size_t>(n_bins) * n_head);
  size_t cursor = 0;
  for (int b = 1; b <= n_bins; ++b) {
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
      double* w = &table->weights_[cursor];
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
      // Padding entries stay exactly 0 (the vector is value-initialised).
      for (int i = 0; i < side * stride; ++i) w[i] /= sum;
      ImpactKernel& kernel = table->kernels_[static_cast<size_t>(b - 1) * n_head + k];
      kernel.half_width = hw;
      kernel.offset_x_m = hb.fall.distance_m * c;
      kernel.offset_y_m = hb.fall.distance_m * s;
      kernel.weights = w;
      cursor += static_cast<size_t>(side) * stride;
    }
  }
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
         kernels_.capacity() * sizeof(ImpactKernel) + weights_.capacity() * sizeof(double);
}

}  // namespace riskplan
