#include "core/risk_model.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"

namespace riskplan {

std::string_view ViolationKindName(ViolationKind kind) {
  switch (kind) {
    case ViolationKind::kNone:
      return "NONE";
    case ViolationKind::kOutsideMap:
      return "OUTSIDE_MAP";
    case ViolationKind::kNoFlyZone:
      return "NO_FLY_ZONE";
    case ViolationKind::kTerrainCollision:
      return "TERRAIN_COLLISION";
    case ViolationKind::kBelowSafeAltitude:
      return "BELOW_SAFE_ALTITUDE";
    case ViolationKind::kAboveMaxAltitude:
      return "ABOVE_MAX_ALTITUDE";
  }
  return "UNKNOWN";
}

absl::StatusOr<std::shared_ptr<const RiskModel>> RiskModel::Create(
    std::shared_ptr<const RiskMap> map, const ModelParams& params,
    std::shared_ptr<const ImpactTable> table) {
  if (map == nullptr) return absl::InvalidArgumentError("risk model: no map");
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  if (params.max_half_width > RiskMap::kPad) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameter 'max_half_width' (%d) exceeds the largest supported (%d)",
        params.max_half_width, RiskMap::kPad));
  }
  if (table != nullptr &&
      (!SameImpactTableParams(table->params(), params) || table->res_m() != map->res())) {
    return absl::InvalidArgumentError(
        "risk model: the impact table given was built for other parameters or cell size");
  }
  if (table == nullptr) {
    absl::StatusOr<std::shared_ptr<const ImpactTable>> built = ImpactTable::Build(params, map->res());
    if (!built.ok()) return built.status();
    table = *std::move(built);
  }
  auto model = std::shared_ptr<RiskModel>(new RiskModel());
  model->map_ = std::move(map);
  model->table_ = std::move(table);
  model->params_ = params;
  if (model->map_->glide_ratio() == params.glide_ratio &&
      model->map_->glide_clearance_m() == params.glide_clearance_m) {
    model->glide_ = &model->map_->glide_altitude();
  } else {
    const RiskMap& m = *model->map_;
    model->own_glide_ = std::make_shared<const std::vector<double>>(ComputeGlideAltitude(
        m.nx(), m.ny(), m.res(), m.layers().terrain, m.layers().nofly, m.landing_sites(),
        params.glide_ratio, params.glide_clearance_m));
    model->glide_ = model->own_glide_.get();
  }
  return std::shared_ptr<const RiskModel>(std::move(model));
}

double RiskModel::SafeAltitude(int i, int j) const {
  const double floor_alt = static_cast<double>(map_->terrain(i, j)) + params_.min_agl_m;
  if (map_->landing_sites().empty()) return floor_alt;
  return std::max(floor_alt, (*glide_)[map_->Index(i, j)]);
}

ViolationKind RiskModel::CheckConfiguration(const Pose& q, double* limit_m) const {
  if (limit_m != nullptr) *limit_m = std::numeric_limits<double>::quiet_NaN();
  int i = 0;
  int j = 0;
  if (!std::isfinite(q.z) || !map_->CellOf(q.x, q.y, &i, &j)) return ViolationKind::kOutsideMap;
  if (map_->nofly(i, j)) return ViolationKind::kNoFlyZone;
  const double terrain = map_->terrain(i, j);
  if (q.z <= terrain) {
    if (limit_m != nullptr) *limit_m = terrain;
    return ViolationKind::kTerrainCollision;
  }
  const double safe = SafeAltitude(i, j);
  if (q.z < safe) {
    if (limit_m != nullptr) *limit_m = safe;
    return ViolationKind::kBelowSafeAltitude;
  }
  const double ceiling = terrain + params_.max_agl_m;
  if (q.z > ceiling) {
    if (limit_m != nullptr) *limit_m = ceiling;
    return ViolationKind::kAboveMaxAltitude;
  }
  return ViolationKind::kNone;
}

void RiskModel::Ewmm(const ImpactKernel& kernel, int ci, int cj, double* impact_factor,
                     double* expected_shelter) const {
  const int hw = kernel.half_width;
  const int side = kernel.Side();
  const RiskMap& m = *map_;
  double sum_rho = 0.0;
  double sum_shelter = 0.0;
  const bool inside_padding = ci - hw >= -RiskMap::kPad && cj - hw >= -RiskMap::kPad &&
                              ci + hw < m.nx() + RiskMap::kPad &&
                              cj + hw < m.ny() + RiskMap::kPad;
  if (inside_padding) {
    for (int v = 0; v < side; ++v) {
      const int64_t row = m.PaddedIndex(ci - hw, cj - hw + v);
      const float* rho = m.padded_density() + row;
      const float* shelter = m.padded_shelter() + row;
      const double* w = kernel.weights + static_cast<int64_t>(v) * side;
      for (int u = 0; u < side; ++u) {
        sum_rho += w[u] * rho[u];
        sum_shelter += w[u] * shelter[u];
      }
    }
  } else {
    // Far outside the map (only with unusual parameters): read cell by cell.
    for (int v = 0; v < side; ++v) {
      for (int u = 0; u < side; ++u) {
        const int i = ci - hw + u;
        const int j = cj - hw + v;
        const double w = kernel.weights[v * side + u];
        if (m.Contains(i, j)) {
          sum_rho += w * m.density(i, j);
          sum_shelter += w * m.shelter(i, j);
        } else {
          sum_shelter += w * 10.0;
        }
      }
    }
  }
  *impact_factor = sum_rho;
  *expected_shelter = sum_shelter;
}

ConfigurationRisk RiskModel::Evaluate(const Pose& q) const {
  ConfigurationRisk out;
  int i = 0;
  int j = 0;
  if (!std::isfinite(q.z) || !std::isfinite(q.theta) || !map_->CellOf(q.x, q.y, &i, &j)) {
    return out;
  }
  const double h = q.z - static_cast<double>(map_->terrain(i, j));
  if (!(h > 0.0)) return out;
  const ImpactTable& t = *table_;
  const int b = t.HeightBinOf(h);
  const int k = t.HeadingBinOf(q.theta);
  const ImpactKernel& kernel = t.kernel(b, k);
  const HeightBin& bin = t.bin(b);
  const double ix = std::floor((q.x + kernel.offset_x_m - map_->x0()) / map_->res());
  const double iy = std::floor((q.y + kernel.offset_y_m - map_->y0()) / map_->res());
  double impact_factor = 0.0;
  double shelter = 0.0;
  Ewmm(kernel, static_cast<int>(ix), static_cast<int>(iy), &impact_factor, &shelter);
  out.impact_factor = impact_factor;
  out.expected_shelter = shelter;
  out.casualty_probability =
      CasualtyProbability(bin.fall.energy_j, shelter, params_.alpha_j, params_.beta_j);
  out.exposed_area_m2 = bin.exposed_area_m2;
  out.risk = out.exposed_area_m2 * out.casualty_probability * impact_factor;
  out.height_bin = b;
  out.heading_bin = k;
  out.defined = true;
  return out;
}

}  // namespace riskplan
