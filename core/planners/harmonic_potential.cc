#include "core/planners/harmonic_potential.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/base/check.h"

namespace riskplan {

HarmonicPotential::HarmonicPotential(int nx, int ny)
    : nx_(nx), ny_(ny), stride_(static_cast<size_t>(nx) + 2) {
  RISKPLAN_DCHECK(nx >= 1 && ny >= 1);
  const size_t cells = stride_ * (static_cast<size_t>(ny) + 2);
  value_.assign(cells, 0.0);
  kind_.assign(cells, kObstacle);
  for (int j = 0; j < ny; ++j) {
    std::fill_n(kind_.begin() + static_cast<std::ptrdiff_t>(Index(0, j)), nx, kFree);
  }
}

void HarmonicPotential::SetObstacle(int i, int j) {
  RISKPLAN_DCHECK(i >= 0 && j >= 0 && i < nx_ && j < ny_);
  kind_[Index(i, j)] = kObstacle;
  value_[Index(i, j)] = 0.0;
}

void HarmonicPotential::SetGoal(int i, int j) {
  RISKPLAN_DCHECK(i >= 0 && j >= 0 && i < nx_ && j < ny_);
  kind_[Index(i, j)] = kGoal;
  value_[Index(i, j)] = 1.0;
}

void HarmonicPotential::SetFree(int i, int j) {
  RISKPLAN_DCHECK(i >= 0 && j >= 0 && i < nx_ && j < ny_);
  kind_[Index(i, j)] = kFree;
}

bool HarmonicPotential::IsObstacle(int i, int j) const {
  RISKPLAN_DCHECK(i >= 0 && j >= 0 && i < nx_ && j < ny_);
  return kind_[Index(i, j)] == kObstacle;
}

double HarmonicPotential::Value(int i, int j) const {
  if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return 0.0;
  return value_[Index(i, j)];
}

bool HarmonicPotential::Sweep(double omega, double tolerance) {
  bool changed = false;
  double* v = value_.data();
  const uint8_t* kind = kind_.data();
  const size_t w = stride_;
  for (int colour = 0; colour < 2; ++colour) {
    for (int j = 1; j <= ny_; ++j) {
      const size_t row = static_cast<size_t>(j) * w;
      // Padded cell (i, j) has colour (i + j) % 2.
      for (size_t i = 1 + static_cast<size_t>((j + 1 + colour) & 1); i <= static_cast<size_t>(nx_);
           i += 2) {
        const size_t k = row + i;
        if (kind[k] != kFree) continue;
        const double old = v[k];
        const double average = 0.25 * ((v[k - 1] + v[k + 1]) + (v[k - w] + v[k + w]));
        const double updated = old + omega * (average - old);
        v[k] = updated;
        // Written so that it is also true when old == 0 and updated != 0.
        if (std::abs(updated - old) > tolerance * std::abs(updated)) changed = true;
      }
    }
  }
  return !changed;
}

std::optional<std::vector<GridCell>> HarmonicPotential::Descend(GridCell from) const {
  std::vector<GridCell> path = {from};
  if (from.i < 0 || from.j < 0 || from.i >= nx_ || from.j >= ny_) return std::nullopt;
  const size_t limit = static_cast<size_t>(nx_) * ny_;
  GridCell at = from;
  while (kind_[Index(at.i, at.j)] != kGoal) {
    if (path.size() > limit) return std::nullopt;
    double best = Value(at.i, at.j);
    GridCell next = at;
    const GridCell neighbours[4] = {
        {at.i + 1, at.j}, {at.i, at.j + 1}, {at.i - 1, at.j}, {at.i, at.j - 1}};
    for (const GridCell& n : neighbours) {
      const double value = Value(n.i, n.j);
      if (value > best) {
        best = value;
        next = n;
      }
    }
    if (next == at) return std::nullopt;
    at = next;
    path.push_back(at);
  }
  return path;
}

double HarmonicPotential::OptimalOmega(int nx, int ny) {
  const double pi = std::numbers::pi;
  const double rho = 0.5 * (std::cos(pi / (nx + 1)) + std::cos(pi / (ny + 1)));
  return 2.0 / (1.0 + std::sqrt(1.0 - rho * rho));
}

}  // namespace riskplan
