#include "geo/grid_regions.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/base/check.h"

namespace riskplan::geo {

std::vector<int32_t> LabelComponents(const std::vector<uint8_t>& mask, int nx, int ny,
                                     int32_t* count) {
  RISKPLAN_DCHECK(mask.size() == static_cast<size_t>(nx) * ny);
  std::vector<int32_t> labels(mask.size(), 0);
  // A flood fill on an explicit stack, not by recursion: a region of
  // millions of cells would overflow the thread's stack.
  std::vector<int64_t> stack;
  int32_t next = 0;
  for (int64_t start = 0; start < static_cast<int64_t>(mask.size()); ++start) {
    if (mask[start] == 0 || labels[start] != 0) continue;
    labels[start] = ++next;
    stack.push_back(start);
    while (!stack.empty()) {
      const int64_t c = stack.back();
      stack.pop_back();
      const int i = static_cast<int>(c % nx), j = static_cast<int>(c / nx);
      const int64_t neighbours[4] = {i > 0 ? c - 1 : -1, i + 1 < nx ? c + 1 : -1,
                                     j > 0 ? c - nx : -1, j + 1 < ny ? c + nx : -1};
      for (int64_t n : neighbours) {
        if (n >= 0 && mask[n] != 0 && labels[n] == 0) {
          labels[n] = next;
          stack.push_back(n);
        }
      }
    }
  }
  *count = next;
  return labels;
}

std::vector<float> DepthInside(const std::vector<int32_t>& labels, int nx, int ny) {
  RISKPLAN_DCHECK(labels.size() == static_cast<size_t>(nx) * ny);
  // Two-pass 3-4 chamfer transform. A neighbour outside the map, or with
  // another label, is at distance 0: the region's edge.
  // Half the largest int, so that kInf plus a step cannot overflow.
  constexpr int kInf = std::numeric_limits<int>::max() / 2;
  std::vector<int> d(labels.size());
  for (size_t c = 0; c < labels.size(); ++c) d[c] = labels[c] > 0 ? kInf : 0;
  auto at = [&](int i, int j, int32_t label) {
    if (i < 0 || j < 0 || i >= nx || j >= ny) return 0;
    const size_t c = static_cast<size_t>(j) * nx + i;
    return labels[c] == label ? d[c] : 0;
  };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const size_t c = static_cast<size_t>(j) * nx + i;
      const int32_t l = labels[c];
      if (l <= 0) continue;
      d[c] = std::min({d[c], at(i - 1, j, l) + 3, at(i, j - 1, l) + 3, at(i - 1, j - 1, l) + 4,
                       at(i + 1, j - 1, l) + 4, at(i + 1, j, l) + 3, at(i, j + 1, l) + 3,
                       at(i - 1, j + 1, l) + 4, at(i + 1, j + 1, l) + 4});
    }
  }
  for (int j = ny - 1; j >= 0; --j) {
    for (int i = nx - 1; i >= 0; --i) {
      const size_t c = static_cast<size_t>(j) * nx + i;
      const int32_t l = labels[c];
      if (l <= 0) continue;
      d[c] = std::min({d[c], at(i + 1, j, l) + 3, at(i, j + 1, l) + 3, at(i + 1, j + 1, l) + 4,
                       at(i - 1, j + 1, l) + 4});
    }
  }
  std::vector<float> depth(labels.size());
  // A step costs 3 (straight) or 4 (diagonal, about 3 sqrt 2): thirds of a
  // cell, in integers.
  for (size_t c = 0; c < d.size(); ++c) depth[c] = static_cast<float>(d[c]) / 3.0f;
  return depth;
}

std::vector<Region> Regions(const std::vector<int32_t>& labels, int32_t count, int nx, int ny,
                            const std::vector<uint8_t>& excluded) {
  const std::vector<float> depth = DepthInside(labels, nx, ny);
  auto usable = [&](size_t c) {
    const int32_t l = labels[c];
    return l > 0 && l <= count && (excluded.empty() || excluded[c] == 0);
  };
  std::vector<Region> regions(static_cast<size_t>(count));
  std::vector<float> deepest(static_cast<size_t>(count), -1.0f);
  for (int32_t k = 0; k < count; ++k) regions[k].label = k + 1;
  for (size_t c = 0; c < labels.size(); ++c) {
    const int32_t l = labels[c];
    if (l <= 0 || l > count) continue;
    ++regions[l - 1].cells;
    if (usable(c)) deepest[l - 1] = std::max(deepest[l - 1], depth[c]);
  }
  // Of a region's deepest cells (a ridge, in an elongated field), the one
  // nearest their mean: the middle of the ridge, not its first cell.
  std::vector<double> sum_i(static_cast<size_t>(count), 0.0), sum_j(sum_i), n(sum_i);
  for (size_t c = 0; c < labels.size(); ++c) {
    if (!usable(c) || depth[c] != deepest[labels[c] - 1]) continue;
    const size_t k = labels[c] - 1;
    sum_i[k] += static_cast<double>(c % nx);
    sum_j[k] += static_cast<double>(c / nx);
    n[k] += 1.0;
  }
  std::vector<double> best(static_cast<size_t>(count), std::numeric_limits<double>::infinity());
  for (size_t c = 0; c < labels.size(); ++c) {
    if (!usable(c) || depth[c] != deepest[labels[c] - 1]) continue;
    const size_t k = labels[c] - 1;
    const int i = static_cast<int>(c % nx), j = static_cast<int>(c / nx);
    const double di = i - sum_i[k] / n[k], dj = j - sum_j[k] / n[k];
    const double d2 = di * di + dj * dj;
    if (d2 < best[k]) {
      best[k] = d2;
      regions[k].deepest_i = i;
      regions[k].deepest_j = j;
      regions[k].depth = depth[c];
    }
  }
  std::vector<Region> kept;
  for (int32_t k = 0; k < count; ++k) {
    if (deepest[k] >= 0.0f) kept.push_back(regions[k]);
  }
  return kept;
}

}  // namespace riskplan::geo
