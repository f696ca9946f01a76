#include "core/planners/lower_bound.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "absl/strings/str_format.h"
#include "core/risk/impact_table.h"

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// out[j * nx + i] = op over the (2w + 1)^2 cells around (i, j) inside the map.
std::vector<float> Filter(const std::vector<float>& in, int nx, int ny, int w,
                          const std::function<float(float, float)>& op) {
  std::vector<float> rows(in.size());
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      float v = in[static_cast<size_t>(j) * nx + i];
      for (int d = std::max(0, i - w); d <= std::min(nx - 1, i + w); ++d) {
        v = op(v, in[static_cast<size_t>(j) * nx + d]);
      }
      rows[static_cast<size_t>(j) * nx + i] = v;
    }
  }
  std::vector<float> out(in.size());
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      float v = rows[static_cast<size_t>(j) * nx + i];
      for (int d = std::max(0, j - w); d <= std::min(ny - 1, j + w); ++d) {
        v = op(v, rows[static_cast<size_t>(d) * nx + i]);
      }
      out[static_cast<size_t>(j) * nx + i] = v;
    }
  }
  return out;
}

}  // namespace

absl::StatusOr<std::unique_ptr<RiskLowerBound>> RiskLowerBound::Build(
    std::shared_ptr<const RiskModel> model, const LowerBoundOptions& options) {
  if (model == nullptr) return absl::InvalidArgumentError("lower bound: model is null");
  const RiskMap& map = model->map();
  const ModelParams& mp = model->params();
  const ImpactTable& table = model->table();
  const double res = map.res();
  if (!(options.block_m >= res) || !std::isfinite(options.block_m) ||
      options.block_m > std::max(map.width_m(), map.height_m())) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "lower bound block_m has value %g; it must be at least the map's cell (%g m) and at most "
        "its side",
        options.block_m, res));
  }
  if (options.ring < 2 || options.ring > 16) {
    return absl::InvalidArgumentError(
        absl::StrFormat("lower bound ring has value %d; it must be in [2, 16]", options.ring));
  }
  std::unique_ptr<RiskLowerBound> lb(new RiskLowerBound());
  lb->model_ = model;
  lb->block_m_ = options.block_m;
  lb->ring_ = options.ring;
  lb->nbx_ = static_cast<int>(std::ceil(map.width_m() / options.block_m));
  lb->nby_ = static_cast<int>(std::ceil(map.height_m() / options.block_m));
  const int nx = map.nx();
  const int ny = map.ny();

  // The reach of a block's samples: half a block and half a sampling step
  // from its centre, one cell more for the floor of the impact cell.
  const double margin = 0.5 * mp.sample_step_m;
  const int w = static_cast<int>(std::ceil((0.5 * options.block_m + margin) / res)) + 1;
  const std::vector<float> rho =
      Filter(map.layers().density, nx, ny, w, [](float a, float b) { return std::min(a, b); });
  const std::vector<float> shelter =
      Filter(map.layers().shelter, nx, ny, w, [](float a, float b) { return std::max(a, b); });

  const int b_lo = table.HeightBinOf(mp.min_agl_m);
  const int b_hi = table.HeightBinOf(mp.max_agl_m);
  const int kbins = table.heading_bins();
  const double per_metre = mp.failure_rate_per_s / (mp.airspeed_mps + mp.wind_speed_mps);
  lb->rate_.assign(static_cast<size_t>(lb->nbx_) * lb->nby_, kInf);
  for (int bj = 0; bj < lb->nby_; ++bj) {
    for (int bi = 0; bi < lb->nbx_; ++bi) {
      // Closed when every cell within the block's reach is no-fly.
      const double bx0 = map.x0() + bi * options.block_m - margin;
      const double by0 = map.y0() + bj * options.block_m - margin;
      const int ci0 = std::max(0, static_cast<int>(std::floor((bx0 - map.x0()) / res)));
      const int cj0 = std::max(0, static_cast<int>(std::floor((by0 - map.y0()) / res)));
      const int ci1 = std::min(
          nx - 1,
          static_cast<int>(std::floor((bx0 + options.block_m + 2 * margin - map.x0()) / res)));
      const int cj1 = std::min(
          ny - 1,
          static_cast<int>(std::floor((by0 + options.block_m + 2 * margin - map.y0()) / res)));
      bool open = false;
      for (int cj = cj0; cj <= cj1 && !open; ++cj) {
        for (int ci = ci0; ci <= ci1 && !open; ++ci) open = !map.nofly(ci, cj);
      }
      if (!open) continue;
      const double cx =
          map.x0() + std::min((bi + 0.5) * options.block_m, map.width_m() - 0.5 * res);
      const double cy =
          map.y0() + std::min((bj + 0.5) * options.block_m, map.height_m() - 0.5 * res);
      double least = kInf;
      for (int b = b_lo; b <= b_hi && least > 0.0; ++b) {
        for (int k = 0; k < kbins && least > 0.0; ++k) {
          const ImpactKernel& kernel = table.kernel(b, k);
          const int hw = kernel.half_width;
          const int ci = static_cast<int>(std::floor((cx + kernel.offset_x_m - map.x0()) / res));
          const int cj = static_cast<int>(std::floor((cy + kernel.offset_y_m - map.y0()) / res));
          if (ci - hw < 0 || cj - hw < 0 || ci + hw >= nx || cj + hw >= ny) {
            least = 0.0;  // unknown ground within reach: nothing is claimed
            break;
          }
          const int side = kernel.Side();
          const int stride = kernel.Stride();
          double impact = 0.0;
          double shelter_sum = 0.0;
          for (int v = 0; v < side; ++v) {
            const double* wrow = kernel.weights + static_cast<int64_t>(v) * stride;
            const size_t row = static_cast<size_t>(cj - hw + v) * nx + (ci - hw);
            for (int u = 0; u < side; ++u) {
              impact += wrow[u] * static_cast<double>(rho[row + u]);
              shelter_sum += wrow[u] * static_cast<double>(shelter[row + u]);
            }
          }
          // Rounding: the sums may differ from the model's by a few ulps;
          // shave them so that the bound stays below.
          impact *= 1.0 - 1e-9;
          shelter_sum = std::min(10.0, shelter_sum * (1.0 + 1e-9));
          const double p = CasualtyProbability(kernel.energy_j, shelter_sum, mp.alpha_j, mp.beta_j);
          least = std::min(least, kernel.exposed_area_m2 * p * impact * (1.0 - 1e-9));
        }
      }
      lb->rate_[static_cast<size_t>(bj) * lb->nbx_ + bi] = per_metre * std::max(0.0, least);
    }
  }
  // The least rate within ring - 1 blocks of each block (closed blocks left
  // out; +inf when all are closed).
  const int r = options.ring - 1;
  lb->ring_rate_.assign(lb->rate_.size(), kInf);
  for (int bj = 0; bj < lb->nby_; ++bj) {
    for (int bi = 0; bi < lb->nbx_; ++bi) {
      double least = kInf;
      for (int nj = std::max(0, bj - r); nj <= std::min(lb->nby_ - 1, bj + r); ++nj) {
        for (int ni = std::max(0, bi - r); ni <= std::min(lb->nbx_ - 1, bi + r); ++ni) {
          least = std::min(least, lb->BlockRate(ni, nj));
        }
      }
      lb->ring_rate_[static_cast<size_t>(bj) * lb->nbx_ + bi] = least;
    }
  }
  return lb;
}

double RiskLowerBound::Query(const Pose& start, const Pose& goal) const {
  const RiskMap& map = model_->map();
  const double b = block_m_;
  const int K = ring_;
  const int nbx = nbx_;
  const int nby = nby_;
  auto block_of = [&](const Pose& p, int* bi, int* bj) {
    *bi = std::clamp(static_cast<int>(std::floor((p.x - map.x0()) / b)), 0, nbx - 1);
    *bj = std::clamp(static_cast<int>(std::floor((p.y - map.y0()) / b)), 0, nby - 1);
  };
  // Least distance from a point to block (bi, bj).
  auto point_block = [&](const Pose& p, int bi, int bj) {
    const double x0 = map.x0() + bi * b;
    const double y0 = map.y0() + bj * b;
    const double dx = std::max({x0 - p.x, 0.0, p.x - (x0 + b)});
    const double dy = std::max({y0 - p.y, 0.0, p.y - (y0 + b)});
    return std::hypot(dx, dy);
  };
  int sbi = 0, sbj = 0, gbi = 0, gbj = 0;
  block_of(start, &sbi, &sbj);
  block_of(goal, &gbi, &gbj);
  auto chebyshev = [](int ai, int aj, int bi, int bj) {
    return std::max(std::abs(ai - bi), std::abs(aj - bj));
  };
  // A track that never reaches a block K away from the start's block stays
  // where the start's ring least holds.
  double best = kInf;
  if (chebyshev(sbi, sbj, gbi, gbj) < K) {
    best = RingRate(sbi, sbj) * std::hypot(goal.x - start.x, goal.y - start.y);
  }
  // Dijkstra over checkpoint blocks: each the first block K away from the
  // previous one.
  const size_t n = static_cast<size_t>(nbx) * nby;
  std::vector<double> dist(n, kInf);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  auto ring_edges = [&](int bi, int bj, double d, double from_rate,
                        const std::function<double(int, int)>& length) {
    for (int dj = -K; dj <= K; ++dj) {
      for (int di = -K; di <= K; ++di) {
        if (std::max(std::abs(di), std::abs(dj)) != K) continue;
        const int ni = bi + di;
        const int nj = bj + dj;
        if (ni < 0 || nj < 0 || ni >= nbx || nj >= nby) continue;
        if (!std::isfinite(BlockRate(ni, nj))) continue;  // closed: never entered
        const double nd = d + from_rate * length(ni, nj);
        const size_t id = static_cast<size_t>(nj) * nbx + ni;
        if (nd < dist[id]) {
          dist[id] = nd;
          queue.push({nd, static_cast<int>(id)});
        }
      }
    }
  };
  ring_edges(sbi, sbj, 0.0, RingRate(sbi, sbj),
             [&](int ni, int nj) { return point_block(start, ni, nj); });
  while (!queue.empty()) {
    const auto [d, id] = queue.top();
    queue.pop();
    if (d > dist[id] || d >= best) continue;
    const int bi = id % nbx;
    const int bj = id / nbx;
    const double rate = RingRate(bi, bj);
    // The last leg: to the goal, never K away again.
    if (chebyshev(bi, bj, gbi, gbj) < K)
      best = std::min(best, d + rate * point_block(goal, bi, bj));
    ring_edges(bi, bj, d, rate, [&](int ni, int nj) {
      const double gx = std::max(std::abs(ni - bi) - 1, 0) * b;
      const double gy = std::max(std::abs(nj - bj) - 1, 0) * b;
      return std::hypot(gx, gy);
    });
  }
  return best;
}

}  // namespace riskplan
