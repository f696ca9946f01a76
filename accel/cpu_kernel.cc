#include "accel/cpu_kernel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <utility>

#include "accel/batch_locate.h"
#include "accel/exact_ewmm.h"
#include "accel/float_kernel.h"
#include "core/base/check.h"

namespace riskplan::accel {
namespace {

// M(q) from cached values, with the operations of RiskModel::FromSums.
ConfigurationRisk FromCached(const RiskModel& model, const KernelSite& site,
                             const SiteCache::Values& v) {
  ConfigurationRisk out;
  out.impact_factor = v.impact_factor;
  out.expected_shelter = v.expected_shelter;
  out.casualty_probability = v.casualty_probability;
  out.exposed_area_m2 = model.table().kernel(site.height_bin, site.heading_bin).exposed_area_m2;
  out.risk = out.exposed_area_m2 * out.casualty_probability * v.impact_factor;
  out.height_bin = site.height_bin;
  out.heading_bin = site.heading_bin;
  out.defined = true;
  return out;
}

inline void PrefetchWindow(const char* row, int64_t row_bytes, int rows, int window_bytes) {
  for (int v = 0; v < rows; ++v) {
    for (int b = 0; b < window_bytes; b += 64) __builtin_prefetch(row + b);
    __builtin_prefetch(row + window_bytes - 1);
    row += row_bytes;
  }
}

// Along a trajectory, neighbouring windows lie a cell or so apart, so what a
// window needs beyond the windows before it is its leading edge: the rows it
// adds (when it moves north or south) and, in every row, the line holding its
// first or last column (when it moves west or east). Those lines are cold
// (the map streams by once), the rest is in L1. EdgePrefetcher fetches the
// leading edge of every fourth window some windows ahead: about a dozen
// prefetches per window instead of a whole window's hundred.
class EdgePrefetcher {
 public:
  EdgePrefetcher(const float* density, const float* shelter, int64_t map_stride)
      : density_(density), shelter_(shelter), map_stride_(map_stride) {}

  // Prefetches what the window of `side` cells from padded index `first`
  // (cell (i, j) of the padded layers) adds to the last window prefetched.
  void Window(int64_t first, int i, int j, int side) {
    const int cols = (side + 7) / 8 * 8;
    const int di = i - last_i_;
    const int dj = j - last_j_;
    if (!have_ || std::abs(di) > 16 || std::abs(dj) >= side || side != last_side_) {
      for (int v = 0; v < side; ++v) Row(first + v * map_stride_, cols);
    } else {
      // Rows new to this window: whole.
      const int new_from = dj > 0 ? side - dj : 0;
      const int new_to = dj > 0 ? side : -dj;
      for (int v = new_from; v < new_to; ++v) Row(first + v * map_stride_, cols);
      // The others: the line of the leading column.
      if (di != 0) {
        const int64_t column = di > 0 ? cols - 1 : 0;
        for (int v = 0; v < side; ++v) {
          if (v >= new_from && v < new_to) continue;
          const int64_t at = first + v * map_stride_ + column;
          __builtin_prefetch(density_ + at);
          __builtin_prefetch(shelter_ + at);
        }
      }
    }
    have_ = true;
    last_i_ = i;
    last_j_ = j;
    last_side_ = side;
  }

 private:
  void Row(int64_t at, int cols) {
    for (int u = 0; u < cols; u += 16) {
      __builtin_prefetch(density_ + at + u);
      __builtin_prefetch(shelter_ + at + u);
    }
    __builtin_prefetch(density_ + at + cols - 1);
    __builtin_prefetch(shelter_ + at + cols - 1);
  }

  const float* const density_;
  const float* const shelter_;
  const int64_t map_stride_;
  bool have_ = false;
  int last_i_ = 0;
  int last_j_ = 0;
  int last_side_ = 0;
};

// Windows ahead whose leading edges are prefetched along trajectories.
constexpr size_t kEdgeAhead = 16;

// Whether the window of a site (inside the map, as Locate gives only such
// sites) with its rows' zero-weight tails lies inside the padded layers and
// fits the vector loops; if so its kernel and first cell.
inline bool WindowOf(const RiskModel& model, const KernelSite& s, const ImpactKernel** kernel,
                     int64_t* first) {
  const RiskMap& m = model.map();
  const ImpactKernel& k = model.table().kernel(s.height_bin, s.heading_bin);
  *kernel = &k;
  const int hw = k.half_width;
  if (!(s.impact_i - hw >= -RiskMap::kPad && s.impact_j - hw >= -RiskMap::kPad &&
        s.impact_i - hw + k.Stride() <= m.nx() + RiskMap::kPad &&
        s.impact_j + hw < m.ny() + RiskMap::kPad && k.Side() <= kMaxExactSide)) {
    return false;
  }
  *first = m.PaddedIndex(s.impact_i - hw, s.impact_j - hw);
  return true;
}

// Whether most neighbouring windows of `sites` are far apart (then the rows
// of the windows ahead are prefetched).
bool MostlyScattered(std::span<const LocatedSite> sites) {
  size_t jumps = 0;
  for (size_t a = 1; a < sites.size(); ++a) {
    const KernelSite& p = sites[a - 1].site;
    const KernelSite& q = sites[a].site;
    jumps += std::abs(p.impact_i - q.impact_i) > 8 || std::abs(p.impact_j - q.impact_j) > 8;
  }
  return 2 * jumps > sites.size();
}

// Prefetches the windows of sites[from, from + count) in both layers.
void PrefetchSites(const RiskModel& model, std::span<const LocatedSite> sites, size_t from,
                   int count, const float* density, const float* shelter, int64_t row_bytes) {
  for (int p = 0; p < count && from + p < sites.size(); ++p) {
    const ImpactKernel* k;
    int64_t first;
    if (WindowOf(model, sites[from + p].site, &k, &first)) {
      const int bytes = (k->Side() + 3) / 4 * 4 * static_cast<int>(sizeof(float));
      PrefetchWindow(reinterpret_cast<const char*>(density + first), row_bytes, k->Side(), bytes);
      PrefetchWindow(reinterpret_cast<const char*>(shelter + first), row_bytes, k->Side(), bytes);
    }
  }
}

// Prefetches the leading edges of every fourth window of `sites` from
// *next up to `until`.
void PrefetchEdgesAhead(const RiskModel& model, std::span<const LocatedSite> sites, size_t until,
                        size_t* next, EdgePrefetcher* edges) {
  for (; *next < sites.size() && *next <= until; *next += 4) {
    const KernelSite& s = sites[*next].site;
    const ImpactKernel* k;
    int64_t first;
    if (WindowOf(model, s, &k, &first)) {
      edges->Window(first, s.impact_i - k->half_width, s.impact_j - k->half_width, k->Side());
    }
  }
}

Isa DetectIsa() {
#if defined(__x86_64__)
  if (__builtin_cpu_supports("avx512f")) return Isa::kAvx512;
  if (__builtin_cpu_supports("avx2")) return Isa::kAvx2;
#endif
  return Isa::kPortable;
}

Isa Resolve(Isa wanted) {
  static const Isa best = DetectIsa();
  if (wanted == Isa::kAuto || static_cast<int>(wanted) > static_cast<int>(best)) return best;
  return wanted;
}

}  // namespace

std::string_view KernelPrecisionName(KernelPrecision precision) {
  return precision == KernelPrecision::kFloat32 ? "float32" : "exact";
}

bool ParseKernelPrecision(std::string_view name, KernelPrecision* precision) {
  if (name == "exact") {
    *precision = KernelPrecision::kExact;
    return true;
  }
  if (name == "float32") {
    *precision = KernelPrecision::kFloat32;
    return true;
  }
  return false;
}

CpuRiskKernel::CpuRiskKernel(PreparedMapCache* maps, SiteCache* sites, CpuKernelOptions options,
                             KernelWeightsCache* weights)
    : maps_(maps),
      site_cache_(sites),
      options_(options),
      isa_(Resolve(options.isa)),
      weights_cache_(weights),
      finisher_(std::make_unique<FastRiskFinisher>()) {}

CpuRiskKernel::~CpuRiskKernel() = default;

const KernelWeights* CpuRiskKernel::WeightsFor(const RiskModel& model, WeightFormat format) {
  if (weights_cache_ == nullptr) return nullptr;
  const int f = static_cast<int>(format);
  const std::shared_ptr<const ImpactTable>& table = model.table_ptr();
  if (last_table_[f].lock() != table) {
    last_weights_[f] = weights_cache_->Get(table, format);
    last_table_[f] = table;
  }
  return last_weights_[f].get();
}

Isa CpuRiskKernel::BestIsa() { return Resolve(Isa::kAuto); }

void CpuRiskKernel::LocateBatch(const RiskModel& model, std::span<const Pose> configs,
                                std::span<ConfigurationRisk> out, std::vector<LocatedSite>* sites) {
  LocateSites(model, configs, out, sites, Resolve(Isa::kAuto) != Isa::kPortable);
}

const float* CpuRiskKernel::DensityFor(const RiskModel& model, const float** shelter) {
  const std::shared_ptr<const RiskMap>& map = model.map_ptr();
  if (maps_ != nullptr && last_map_.lock() != map) {
    last_prepared_ = maps_->Get(map);
    last_map_ = map;
  }
  if (maps_ != nullptr && last_prepared_ != nullptr) {
    *shelter = last_prepared_->shelter();
    return last_prepared_->density();
  }
  *shelter = model.map().padded_shelter();
  return model.map().padded_density();
}

void CpuRiskKernel::Sums(const RiskModel& model, std::span<const LocatedSite> sites,
                         std::span<double> impact_factor, std::span<double> expected_shelter) {
  RISKPLAN_DCHECK(impact_factor.size() == sites.size() && expected_shelter.size() == sites.size());
  const size_t n = sites.size();
  stats_.ewmms += n;
#if defined(__x86_64__)
  if (isa_ != Isa::kPortable && n > 0) {
    const float* shelter = nullptr;
    const float* density = DensityFor(model, &shelter);
    const int64_t map_stride = model.map().padded_nx();
    const int64_t row_bytes = map_stride * static_cast<int64_t>(sizeof(float));
    const int group_max = isa_ == Isa::kAvx512 ? 4 : 2;
    // The same weights, on 64-byte boundaries (null: the table's own).
    const KernelWeights* aligned = WeightsFor(model, WeightFormat::kDouble);
    const auto weights_of = [&](const KernelSite& site, const ImpactKernel* k) {
      return aligned != nullptr ? aligned->doubles(site.height_bin, site.heading_bin) : k->weights;
    };
    // Windows far apart: fetch the rows of the next ones early; along
    // trajectories, their leading edges.
    const bool scattered = MostlyScattered(sites);
    const int distance = scattered ? options_.prefetch_distance : 0;
    EdgePrefetcher edges(density, shelter, map_stride);
    size_t next_edge = 0;
    size_t a = 0;
    while (a < n) {
      if (distance > 0) {
        PrefetchSites(model, sites, a + distance, group_max, density, shelter, row_bytes);
      }
      if (!scattered) PrefetchEdgesAhead(model, sites, a + kEdgeAhead, &next_edge, &edges);
      const ImpactKernel* k0;
      int64_t first0;
      if (!WindowOf(model, sites[a].site, &k0, &first0)) {
        model.Ewmm(*k0, sites[a].site.impact_i, sites[a].site.impact_j, &impact_factor[a],
                   &expected_shelter[a]);
        ++a;
        continue;
      }
      // A group of consecutive windows of the same size goes through one loop.
      ExactWindow group[4];
      group[0] = {weights_of(sites[a].site, k0), density + first0, shelter + first0};
      int count = 1;
      bool shared = true;
      while (count < group_max && a + count < n) {
        const KernelSite& s = sites[a + count].site;
        const ImpactKernel* k;
        int64_t first;
        if (!WindowOf(model, s, &k, &first) || k->Side() != k0->Side()) break;
        shared = shared && k->weights == k0->weights;
        group[count] = {weights_of(s, k), density + first, shelter + first};
        ++count;
      }
      if (count == 3) count = 2;  // loops exist for 1, 2 and 4 windows
      ExactLoopFor(isa_, count, k0->Side(), shared)(group, k0->Side(), k0->Stride(), map_stride,
                                                    &impact_factor[a], &expected_shelter[a]);
      a += count;
    }
    return;
  }
#endif
  const ImpactTable& t = model.table();
  for (size_t a = 0; a < n; ++a) {
    const KernelSite& s = sites[a].site;
    model.Ewmm(t.kernel(s.height_bin, s.heading_bin), s.impact_i, s.impact_j, &impact_factor[a],
               &expected_shelter[a]);
  }
}

void CpuRiskKernel::SumsFloat32(const RiskModel& model, std::span<const LocatedSite> sites,
                                std::span<double> impact_factor,
                                std::span<double> expected_shelter) {
  const KernelWeights* weights = WeightsFor(model, WeightFormat::kFloat32);
  if (weights == nullptr) return Sums(model, sites, impact_factor, expected_shelter);
  const size_t n = sites.size();
  stats_.ewmms += n;
  const Isa isa = FloatIsa(isa_);
  const float* shelter = nullptr;
  const float* density = DensityFor(model, &shelter);
  const int64_t map_stride = model.map().padded_nx();
  const int64_t row_bytes = map_stride * static_cast<int64_t>(sizeof(float));
  const bool scattered = MostlyScattered(sites);
  const int distance = scattered ? options_.prefetch_distance : 0;
  // Along trajectories: the leading edges of the windows ahead.
  EdgePrefetcher edges(density, shelter, map_stride);
  size_t next_edge = 0;
  size_t a = 0;
  while (a < n) {
    if (!scattered) PrefetchEdgesAhead(model, sites, a + kEdgeAhead, &next_edge, &edges);
    const KernelSite& s0 = sites[a].site;
    const ImpactKernel* k0;
    int64_t first0;
    if (!WindowOf(model, s0, &k0, &first0)) {
      // Far off the map or wider than the loops: the exact sums.
      model.Ewmm(*k0, s0.impact_i, s0.impact_j, &impact_factor[a], &expected_shelter[a]);
      ++a;
      continue;
    }
    const int side = k0->Side();
    const int group_max = FloatGroupMax(isa, side);
    if (distance > 0) {
      PrefetchSites(model, sites, a + distance, group_max, density, shelter, row_bytes);
    }
    FloatWindow group[4];
    group[0] = {weights->floats(s0.height_bin, s0.heading_bin), density + first0, shelter + first0};
    int count = 1;
    bool shared = true;
    while (count < group_max && a + count < n) {
      const KernelSite& s = sites[a + count].site;
      const ImpactKernel* k;
      int64_t first;
      if (!WindowOf(model, s, &k, &first) || k->Side() != side) break;
      shared = shared && k->weights == k0->weights;
      group[count] = {weights->floats(s.height_bin, s.heading_bin), density + first,
                      shelter + first};
      ++count;
    }
    if (count == 3) count = 2;  // loops exist for 1, 2 and 4 windows
    FloatLoopFor(isa, count, side, shared)(group, side,
                                           KernelWeights::StrideFor(side, WeightFormat::kFloat32),
                                           map_stride, &impact_factor[a], &expected_shelter[a]);
    a += count;
  }
}

void CpuRiskKernel::Evaluate(const RiskModel& model, std::span<const Pose> configs,
                             std::span<ConfigurationRisk> out) {
  RISKPLAN_DCHECK(out.size() == configs.size() && configs.size() <= (size_t{1} << 32));
  stats_.configurations += configs.size();
  sites_.clear();
  LocateBatch(model, configs, out, &sites_);

  // Repeated sites from the cache. Lookups go in rounds of kRound so that
  // the slots prefetched for a round are still near when they are read.
  SiteCache::Session session;
  const bool cached = site_cache_ != nullptr && site_cache_->enabled();
  if (cached) {
    // Exact and float32 results never share entries.
    session = site_cache_->Begin(model, static_cast<uint32_t>(options_.precision));
    constexpr size_t kRound = 32;
    keys_.resize(kRound);
    size_t kept = 0;
    uint64_t hits = 0;
    for (size_t first = 0; first < sites_.size(); first += kRound) {
      const size_t end = std::min(sites_.size(), first + kRound);
      for (size_t a = first; a < end; ++a) {
        keys_[a - first] = SiteCache::KeyOf(session, sites_[a].site);
        site_cache_->Prefetch(keys_[a - first]);
      }
      for (size_t a = first; a < end; ++a) {
        SiteCache::Values values;
        const uint64_t key = keys_[a - first];
        if (key != 0 && site_cache_->Lookup(session, key, &values)) {
          out[sites_[a].index] = FromCached(model, sites_[a].site, values);
          ++hits;
        } else {
          sites_[kept++] = sites_[a];
        }
      }
    }
    site_cache_->CountLookups(hits, kept);
    stats_.cache_hits += hits;
    sites_.resize(kept);
  }

  if (options_.sort_min_configs > 0 &&
      sites_.size() >= static_cast<size_t>(options_.sort_min_configs)) {
    size_t jumps = 0;
    for (size_t a = 1; a < sites_.size(); ++a) {
      jumps += std::abs(sites_[a - 1].site.impact_i - sites_[a].site.impact_i) > 8 ||
               std::abs(sites_[a - 1].site.impact_j - sites_[a].site.impact_j) > 8;
    }
    if (4 * jumps > sites_.size()) {
      // Two stable counting sorts (column, then row) give row-major order of
      // the impact cells; cells beyond the padding share the edge buckets.
      const RiskMap& m = model.map();
      const int span_i = m.padded_nx();
      const int span_j = m.padded_ny();
      const auto counting_sort = [&](const std::vector<LocatedSite>& from,
                                     std::vector<LocatedSite>* to, int buckets, auto key) {
        counts_.assign(static_cast<size_t>(buckets) + 1, 0);
        for (const LocatedSite& s : from) ++counts_[key(s) + 1];
        for (int b = 0; b < buckets; ++b) counts_[b + 1] += counts_[b];
        for (const LocatedSite& s : from) (*to)[counts_[key(s)]++] = s;
      };
      ordered_.resize(sites_.size());
      counting_sort(sites_, &ordered_, span_i, [&](const LocatedSite& s) {
        return std::clamp(s.site.impact_i + RiskMap::kPad, 0, span_i - 1);
      });
      counting_sort(ordered_, &sites_, span_j, [&](const LocatedSite& s) {
        return std::clamp(s.site.impact_j + RiskMap::kPad, 0, span_j - 1);
      });
    }
  }

  // A site equal to the one before it (consecutive samples of a trajectory
  // that fall in the same impact cell with the same bins) has the same
  // result, bit for bit: it is computed once and copied.
  repeats_.clear();
  if (!sites_.empty()) {
    size_t kept = 1;
    for (size_t a = 1; a < sites_.size(); ++a) {
      const KernelSite& p = sites_[kept - 1].site;
      const KernelSite& q = sites_[a].site;
      if (q.impact_i == p.impact_i && q.impact_j == p.impact_j && q.height_bin == p.height_bin &&
          q.heading_bin == p.heading_bin) {
        repeats_.push_back({sites_[a].index, sites_[kept - 1].index});
      } else {
        sites_[kept++] = sites_[a];
      }
    }
    sites_.resize(kept);
    stats_.repeats += repeats_.size();
  }

  impact_.resize(sites_.size());
  shelter_.resize(sites_.size());
  // The float32 path needs its weights; without them everything is exact.
  const bool float32 = options_.precision == KernelPrecision::kFloat32 &&
                       WeightsFor(model, WeightFormat::kFloat32) != nullptr;
  if (float32) finisher_->PrepareFor(model);
  // Sums and finishing a block at a time, so that a large batch's sums are
  // still in the caches when they are finished.
  constexpr size_t kBlock = 4096;
  for (size_t first = 0; first < sites_.size(); first += kBlock) {
    const size_t n = std::min(kBlock, sites_.size() - first);
    const std::span<const LocatedSite> block(sites_.data() + first, n);
    if (float32) {
      SumsFloat32(model, block, std::span(impact_).subspan(first, n),
                  std::span(shelter_).subspan(first, n));
    } else {
      Sums(model, block, std::span(impact_).subspan(first, n),
           std::span(shelter_).subspan(first, n));
    }
    for (size_t a = first; a < first + n; ++a) {
      const ConfigurationRisk r = float32
                                      ? finisher_->Finish(sites_[a].site, impact_[a], shelter_[a])
                                      : model.FromSums(sites_[a].site, impact_[a], shelter_[a]);
      out[sites_[a].index] = r;
      if (cached) {
        const uint64_t key = SiteCache::KeyOf(session, sites_[a].site);
        if (key != 0) {
          site_cache_->Insert(session, key,
                              {r.impact_factor, r.expected_shelter, r.casualty_probability});
        }
      }
    }
  }
  for (const Repeat& r : repeats_) out[r.index] = out[r.same_as];
}

}  // namespace riskplan::accel
