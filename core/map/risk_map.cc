#include "core/map/risk_map.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/check.h"

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Values in messages: %.9g shows every float exactly enough to tell 10 from
// 10.000001, and prints "nan"/"inf" for non-finite values.
std::string FloatText(double v) { return absl::StrFormat("%.9g", v); }
std::string DoubleText(double v) { return absl::StrFormat("%.17g", v); }

bool ValidNameChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
}

absl::Status CellError(const char* layer, int i, int j, double value, const char* rule) {
  return absl::InvalidArgumentError(absl::StrCat("layer '", layer, "': cell (", i, ", ", j,
                                                 ") has value ", FloatText(value), "; ", rule));
}

absl::Status CheckLayerSize(const char* layer, size_t actual, int64_t expected) {
  if (static_cast<int64_t>(actual) == expected) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat("layer '", layer, "' has ", actual, " entries; expected nx*ny = ", expected));
}

// Scans a layer in index order so that the reported cell is the first bad one
// (south-west first), which makes messages reproducible.
template <typename T, typename Ok>
absl::Status CheckLayerValues(const char* layer, const std::vector<T>& values, int nx, Ok ok,
                              const char* rule) {
  for (size_t k = 0; k < values.size(); ++k) {
    if (!ok(values[k])) {
      const int i = static_cast<int>(k % nx);
      const int j = static_cast<int>(k / nx);
      return CellError(layer, i, j, static_cast<double>(values[k]), rule);
    }
  }
  return absl::OkStatus();
}

// Copies one layer into the centre of a padded raster whose border holds
// `fill` (finite, and never weighed: see RiskMap::padded_density()).
std::vector<float> PadLayer(const std::vector<float>& layer, int nx, int ny, float fill) {
  const int pnx = nx + 2 * RiskMap::kPad;
  const int pny = ny + 2 * RiskMap::kPad;
  std::vector<float> padded(static_cast<size_t>(pnx) * pny, fill);
  for (int j = 0; j < ny; ++j) {
    const float* src = layer.data() + static_cast<size_t>(j) * nx;
    float* dst = padded.data() + static_cast<size_t>(j + RiskMap::kPad) * pnx + RiskMap::kPad;
    std::copy(src, src + nx, dst);
  }
  return padded;
}

// Binary min-heap of (altitude, cell) entries. Besides push and pop it offers
// ReplaceTop(), a pop followed by a push in one sift.
class GlideHeap {
 public:
  struct Entry {
    double alt;
    uint32_t index;
  };

  bool empty() const { return heap_.empty(); }
  const Entry& Top() const { return heap_.front(); }

  void Push(Entry e) {
    size_t at = heap_.size();
    heap_.push_back(e);
    while (at > 0) {
      const size_t parent = (at - 1) / 2;
      if (!(e.alt < heap_[parent].alt)) break;
      heap_[at] = heap_[parent];
      at = parent;
    }
    heap_[at] = e;
  }

  // REQUIRES: !empty().
  void Pop() {
    RISKPLAN_DCHECK(!heap_.empty());
    const Entry last = heap_.back();
    heap_.pop_back();
    if (!heap_.empty()) SiftDown(last);
  }

  // REQUIRES: !empty(). Removes the top and inserts e.
  void ReplaceTop(Entry e) {
    RISKPLAN_DCHECK(!heap_.empty());
    SiftDown(e);
  }

 private:
  // Places e from the root down, Floyd's way: the entries placed here are a
  // popped heap's last entry, or a neighbour one climb step above the popped
  // altitude, so both belong near the bottom. The hole goes down to a leaf
  // along the smaller children without comparing with e (a select rather than
  // a hard-to-predict branch), and e climbs back the short way.
  void SiftDown(Entry e) {
    const size_t n = heap_.size();
    size_t at = 0;
    while (2 * at + 2 < n) {
      const size_t left = 2 * at + 1;
      const size_t child = left + (heap_[left + 1].alt < heap_[left].alt ? 1 : 0);
      heap_[at] = heap_[child];
      at = child;
    }
    if (2 * at + 1 < n) {
      heap_[at] = heap_[2 * at + 1];
      at = 2 * at + 1;
    }
    while (at > 0) {
      const size_t parent = (at - 1) / 2;
      if (!(e.alt < heap_[parent].alt)) break;
      heap_[at] = heap_[parent];
      at = parent;
    }
    heap_[at] = e;
  }

  std::vector<Entry> heap_;
};

}  // namespace

absl::Status ValidateMapHeader(const MapHeader& header) {
  const std::string& name = header.name;
  bool name_ok = !name.empty() && name.size() <= 64;
  for (char c : name) name_ok = name_ok && ValidNameChar(c);
  if (!name_ok) {
    return absl::InvalidArgumentError(absl::StrCat(
        "map header: name '", name, "' is invalid; it must be 1 to 64 characters of [a-z0-9._-]"));
  }
  if (!(std::isfinite(header.res) && header.res > 0.0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "map header: res has value ", DoubleText(header.res), "; res must be > 0 and finite"));
  }
  if (!std::isfinite(header.x0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("map header: x0 has value ", DoubleText(header.x0), "; x0 must be finite"));
  }
  if (!std::isfinite(header.y0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("map header: y0 has value ", DoubleText(header.y0), "; y0 must be finite"));
  }
  for (auto [field, value] : {std::pair{"nx", header.nx}, std::pair{"ny", header.ny}}) {
    if (value <= 0 || value > kMaxMapSide) {
      return absl::InvalidArgumentError(absl::StrCat("map header: ", field, " has value ", value,
                                                     "; ", field, " must be in [1, ", kMaxMapSide,
                                                     "]"));
    }
  }
  const int64_t cells = static_cast<int64_t>(header.nx) * header.ny;
  if (cells > kMaxMapCells) {
    return absl::InvalidArgumentError(
        absl::StrCat("map header: nx*ny = ", cells, " cells exceeds the limit of ", kMaxMapCells));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<const RiskMap>> RiskMap::Create(MapHeader header, MapLayers layers,
                                                               double glide_ratio,
                                                               double glide_clearance_m) {
  if (absl::Status s = ValidateMapHeader(header); !s.ok()) return s;
  if (!(std::isfinite(glide_ratio) && glide_ratio > 0.0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "glide_ratio has value ", DoubleText(glide_ratio), "; glide_ratio must be > 0 and finite"));
  }
  if (!(std::isfinite(glide_clearance_m) && glide_clearance_m >= 0.0)) {
    return absl::InvalidArgumentError(absl::StrCat("glide_clearance_m has value ",
                                                   DoubleText(glide_clearance_m),
                                                   "; glide_clearance_m must be >= 0 and finite"));
  }

  const int nx = header.nx;
  const int ny = header.ny;
  const int64_t cells = static_cast<int64_t>(nx) * ny;
  for (absl::Status s : {CheckLayerSize("density", layers.density.size(), cells),
                         CheckLayerSize("shelter", layers.shelter.size(), cells),
                         CheckLayerSize("terrain", layers.terrain.size(), cells),
                         CheckLayerSize("nofly", layers.nofly.size(), cells)}) {
    if (!s.ok()) return s;
  }

  // std::isfinite on float is exact; the negated comparisons also reject NaN.
  if (absl::Status s = CheckLayerValues(
          "density", layers.density, nx, [](float v) { return std::isfinite(v) && v >= 0.0f; },
          "density must be >= 0 and finite");
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckLayerValues(
          "shelter", layers.shelter, nx, [](float v) { return v >= 0.0f && v <= 10.0f; },
          "shelter must be in [0, 10] and finite");
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckLayerValues(
          "terrain", layers.terrain, nx, [](float v) { return std::isfinite(v); },
          "terrain must be finite");
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckLayerValues(
          "nofly", layers.nofly, nx, [](uint8_t v) { return v <= 1; }, "nofly must be 0 or 1");
      !s.ok()) {
    return s;
  }
  for (const LandingSite& site : layers.landing_sites) {
    if (site.i < 0 || site.j < 0 || site.i >= nx || site.j >= ny) {
      return absl::InvalidArgumentError(
          absl::StrCat("layer 'landing_sites': site '", site.name, "' at cell (", site.i, ", ",
                       site.j, ") is outside the map of ", nx, " x ", ny, " cells"));
    }
  }

  // The constructor is private, so make_shared cannot reach it.
  std::shared_ptr<RiskMap> map(new RiskMap());
  auto glide = std::make_shared<const std::vector<double>>(
      ComputeGlideAltitude(nx, ny, header.res, layers.terrain, layers.nofly, layers.landing_sites,
                           glide_ratio, glide_clearance_m));
  auto shared = std::make_shared<Shared>();
  const auto [terrain_min, terrain_max] =
      std::minmax_element(layers.terrain.begin(), layers.terrain.end());
  shared->terrain_min_m = *terrain_min;
  shared->terrain_max_m = *terrain_max;
  shared->padded_density = PadLayer(layers.density, nx, ny, 0.0f);
  shared->padded_shelter = PadLayer(layers.shelter, nx, ny, 10.0f);
  shared->layers = std::move(layers);
  map->glide_altitude_ = std::move(glide);
  map->glide_ratio_ = glide_ratio;
  map->glide_clearance_m_ = glide_clearance_m;
  map->header_ = std::move(header);
  // An aliasing pointer: the no-fly layer lives as long as the shared layers.
  map->nofly_layer_ = std::shared_ptr<const std::vector<uint8_t>>(shared, &shared->layers.nofly);
  map->shared_ = std::move(shared);
  map->density_ = map->shared_->layers.density.data();
  map->shelter_ = map->shared_->layers.shelter.data();
  map->terrain_ = map->shared_->layers.terrain.data();
  map->nofly_ = map->nofly_layer_->data();
  return std::shared_ptr<const RiskMap>(std::move(map));
}

absl::StatusOr<std::shared_ptr<const RiskMap>> RiskMap::WithNoFly(
    const std::shared_ptr<const RiskMap>& base, std::vector<uint8_t> nofly,
    const StopCondition& stop, GlideRepairStats* stats) {
  if (base == nullptr) return absl::InvalidArgumentError("RiskMap::WithNoFly: no base map");
  const int64_t cells = static_cast<int64_t>(base->nx()) * base->ny();
  if (absl::Status s = CheckLayerSize("nofly", nofly.size(), cells); !s.ok()) return s;
  if (absl::Status s = CheckLayerValues(
          "nofly", nofly, base->nx(), [](uint8_t v) { return v <= 1; }, "nofly must be 0 or 1");
      !s.ok()) {
    return s;
  }
  std::vector<double> glide = base->glide_altitude();
  if (absl::Status s = RepairGlideAltitude(
          base->nx(), base->ny(), base->res(), base->layers().terrain, base->landing_sites(),
          base->glide_ratio(), base->glide_clearance_m(), GlideWind{}, base->nofly_layer(), nofly,
          &glide, stop, stats);
      !s.ok()) {
    return s;
  }
  std::shared_ptr<RiskMap> map(new RiskMap(*base));
  map->nofly_layer_ = std::make_shared<const std::vector<uint8_t>>(std::move(nofly));
  map->nofly_ = map->nofly_layer_->data();
  map->glide_altitude_ = std::make_shared<const std::vector<double>>(std::move(glide));
  return std::shared_ptr<const RiskMap>(std::move(map));
}

bool RiskMap::CellOf(double x, double y, int* i, int* j) const {
  const double fx = std::floor((x - header_.x0) / header_.res);
  const double fy = std::floor((y - header_.y0) / header_.res);
  // Compare as doubles before converting: a far-away or NaN coordinate must not
  // reach the (undefined) double-to-int conversion. NaN fails every comparison.
  if (!(fx >= 0.0 && fx < header_.nx && fy >= 0.0 && fy < header_.ny)) return false;
  *i = static_cast<int>(fx);
  *j = static_cast<int>(fy);
  return true;
}

double RiskMap::SafeAltitude(int i, int j, double min_agl_m) const {
  RISKPLAN_DCHECK(Contains(i, j));
  const double floor_alt = static_cast<double>(terrain(i, j)) + min_agl_m;
  if (shared_->layers.landing_sites.empty()) return floor_alt;
  return std::max(floor_alt, (*glide_altitude_)[Index(i, j)]);
}

size_t RiskMap::MemoryBytes() const {
  const MapLayers& layers = shared_->layers;
  size_t bytes = sizeof(*this) + sizeof(Shared);
  bytes += layers.density.capacity() * sizeof(float);
  bytes += layers.shelter.capacity() * sizeof(float);
  bytes += layers.terrain.capacity() * sizeof(float);
  bytes += layers.nofly.capacity() * sizeof(uint8_t);
  bytes += layers.landing_sites.capacity() * sizeof(LandingSite);
  for (const LandingSite& site : layers.landing_sites) bytes += site.name.capacity();
  bytes += shared_->padded_density.capacity() * sizeof(float);
  bytes += shared_->padded_shelter.capacity() * sizeof(float);
  if (nofly_layer_.get() != &layers.nofly) bytes += nofly_layer_->capacity() * sizeof(uint8_t);
  bytes += glide_altitude_->capacity() * sizeof(double);
  return bytes;
}

std::vector<double> ComputeGlideAltitude(int nx, int ny, double res,
                                         const std::vector<float>& terrain,
                                         const std::vector<uint8_t>& nofly,
                                         const std::vector<LandingSite>& sites, double glide_ratio,
                                         double clearance_m) {
  // Never stopped, so never empty.
  return *ComputeGlideAltitude(nx, ny, res, terrain, nofly, sites, glide_ratio, clearance_m,
                               StopCondition());
}

namespace {

// The eight steps of the glide grid: straight ones first, then diagonals.
constexpr int kDi[8] = {1, -1, 0, 0, 1, 1, -1, -1};
constexpr int kDj[8] = {0, 0, 1, -1, 1, -1, 1, -1};

// The glide altitude a cell of floor `floor` (T + clearance, +infinity when
// no-fly) gets from a neighbour at `alt` over an edge of climb `climb`: spec
// section 6's max(T(c) + clearance, glide(n) + dist(c, n)/G(c->n)). Every
// relaxation and every check of the layer computes it this one way, so they
// agree bit for bit.
inline double GlideStep(double floor, double alt, double climb) {
  return std::max(floor, alt + climb);
}

// The relaxation of the glide Dijkstra, shared by the bucket phase, the heap
// phase and the repair: the cell `index` is settled at `alt`; every
// neighbour c = index + (kDi[d], kDj[d]) whose label GlideStep lowers gets
// the new label, and `lowered(alt_c, c)` is called to queue it. `cells`
// gives Floor(k) and a reference Glide(k) to the label.
template <typename Cells, typename Lowered>
inline void RelaxNeighbours(int nx, int ny, const double (&climb)[8], uint32_t index, double alt,
                            Cells& cells, Lowered&& lowered) {
  const int ci = static_cast<int>(index % static_cast<uint32_t>(nx));
  const int cj = static_cast<int>(index / static_cast<uint32_t>(nx));
  for (int d = 0; d < 8; ++d) {
    const int ni = ci + kDi[d];
    const int nj = cj + kDj[d];
    if (ni < 0 || nj < 0 || ni >= nx || nj >= ny) continue;
    const uint32_t nk = static_cast<uint32_t>(nj) * static_cast<uint32_t>(nx) + ni;
    const double a = GlideStep(cells.Floor(nk), alt, climb[d]);
    double& label = cells.Glide(nk);
    if (a < label) {
      label = a;
      lowered(a, nk);
    }
  }
}

// Everything a relaxation of the full computation reads about a cell sits in
// one 16-byte record: the frontiers around dozens of sites grow at once, all
// over the map, and separate arrays cost a cache miss each per neighbour.
// floor = T + clearance, or +infinity for a no-fly cell, which then can never
// be lowered below its initial +infinity, i.e. is never entered.
struct GlideCell {
  double glide;
  double floor;
};
struct PackedCells {
  std::vector<GlideCell>& v;
  double Floor(uint32_t k) const { return v[k].floor; }
  double& Glide(uint32_t k) { return v[k].glide; }
};

// The floor of cell k as PackedCells holds it.
inline double FloorOf(const std::vector<float>& terrain, const std::vector<uint8_t>& nofly,
                      size_t k, double clearance_m) {
  return nofly[k] != 0 ? kInf : static_cast<double>(terrain[k]) + clearance_m;
}

// The repair's view: labels in the layer itself, floors from the layers.
struct LayerCells {
  std::vector<double>& glide;
  const std::vector<float>& terrain;
  const std::vector<uint8_t>& nofly;
  double clearance_m;
  double Floor(uint32_t k) const { return FloorOf(terrain, nofly, k, clearance_m); }
  double& Glide(uint32_t k) { return glide[k]; }
};

// climb[d]: the height a glide needs per edge d, dist(c, n) / G(c -> n),
// where the search steps from the settled cell n to its neighbour c =
// n + (kDi[d], kDj[d]): the glide flies from c back to n, along -(di, dj).
// +infinity for an edge that cannot be glided in the wind.
void GlideClimbs(double res, double glide_ratio, const GlideWind& wind, double (&climb)[8]) {
  // dist(c, n) / G, computed the way the spec writes it.
  const double straight_climb = res / glide_ratio;
  const double diagonal_climb = (res * std::numbers::sqrt2) / glide_ratio;
  for (int d = 0; d < 8; ++d) {
    const double dist = d < 4 ? res : res * std::numbers::sqrt2;
    if (wind.Calm()) {
      climb[d] = d < 4 ? straight_climb : diagonal_climb;
      continue;
    }
    const double norm = d < 4 ? 1.0 : std::numbers::sqrt2;
    const double dx = -kDi[d] / norm;  // d-hat: from c's centre towards n's
    const double dy = -kDj[d] / norm;
    const double along = wind.x * dx + wind.y * dy;   // w . d-hat
    const double across = -wind.x * dy + wind.y * dx;  // w . m-hat, m-hat = (-d_y, d_x)
    const double vg = wind.airspeed_mps;
    if (!(std::fabs(across) < vg)) {
      climb[d] = kInf;
      continue;
    }
    // A ground speed of zero up to rounding (v_g = W and the edge has any
    // headwind: sqrt(v_g^2 - W^2 sin^2) - W cos is 0 in exact arithmetic)
    // is not positive: below 1e-9 v_g the edge is not glided.
    const double ground_speed = std::sqrt(vg * vg - across * across) + along;
    if (!(ground_speed > 1e-9 * vg)) {
      climb[d] = kInf;
      continue;
    }
    climb[d] = dist / (glide_ratio * ground_speed / vg);
  }
}

// Lazy-deletion Dijkstra on (altitude, index) pairs from the entries of
// `heap` over `cells`. The update GlideStep never lowers a value below the
// value it came from, so the first pop of a cell is final, and the result is
// the unique fixed point of the recurrence whatever order ties are popped in.
// Returns the cells settled.
template <typename Cells>
absl::StatusOr<int64_t> SettleInHeap(int nx, int ny, const double (&climb)[8],
                                     const StopCondition& stop, Cells& cells, GlideHeap* heap) {
  int64_t settled_cells = 0;
  for (uint64_t settled = 0; !heap->empty(); ++settled) {
    // A few milliseconds between polls: 2^16 relaxations.
    if ((settled & 0xffff) == 0xffff && stop.Reached()) {
      return absl::CancelledError("glide layer: stopped");
    }
    const GlideHeap::Entry top = heap->Top();
    // Stale entries (a cell lowered after it was pushed) are skipped by value
    // rather than with a settled flag per cell.
    if (top.alt > cells.Glide(top.index)) {
      heap->Pop();
      continue;
    }
    ++settled_cells;
    // The top stays in the heap until the first improved neighbour replaces
    // it: one sift instead of a pop and a push. Most cells are settled this
    // way, as a cell is pushed about once on average.
    bool top_replaced = false;
    RelaxNeighbours(nx, ny, climb, top.index, top.alt, cells, [&](double alt, uint32_t nk) {
      if (top_replaced) {
        heap->Push({alt, nk});
      } else {
        heap->ReplaceTop({alt, nk});
        top_replaced = true;
      }
    });
    if (!top_replaced) heap->Pop();
  }
  return settled_cells;
}

// The bucket phase of ComputeGlideAltitude (see there). `work` holds every
// cell's {glide, floor}; `heap` the sites' entries on entry, and the entries
// left for the heap on return (labels beyond the buckets' reach).
absl::Status SettleInBuckets(int nx, int ny, const double (&climb)[8], const StopCondition& stop,
                             std::vector<GlideCell>* work, GlideHeap* heap) {
  constexpr size_t kMaxBuckets = size_t{1} << 20;
  double min_climb = kInf;
  for (double c : climb) {
    if (c > 0.0) min_climb = std::min(min_climb, c);
  }
  if (heap->empty() || !std::isfinite(min_climb)) return absl::OkStatus();
  const double width = 0.5 * min_climb;
  const double base = heap->Top().alt;  // the lowest label there will ever be
  std::vector<std::vector<GlideHeap::Entry>> buckets;
  std::vector<std::vector<GlideHeap::Entry>> spare;  // emptied buckets' storage, reused
  GlideHeap overflow;
  size_t current = 0;
  const auto place = [&](double alt, uint32_t index) {
    const GlideHeap::Entry e{alt, index};
    const double f = std::floor((e.alt - base) / width);
    if (!(f < static_cast<double>(kMaxBuckets))) {
      overflow.Push(e);
      return;
    }
    // At least two buckets on by construction; never before the current
    // one, whatever the division's rounding.
    const size_t b = std::max(current, static_cast<size_t>(std::max(0.0, f)));
    if (b >= buckets.size()) buckets.resize(b + 1);
    std::vector<GlideHeap::Entry>& v = buckets[b];
    if (v.capacity() == 0 && !spare.empty()) {
      v = std::move(spare.back());
      spare.pop_back();
    }
    v.push_back(e);
  };
  while (!heap->empty()) {
    place(heap->Top().alt, heap->Top().index);
    heap->Pop();
  }
  PackedCells cells{*work};
  uint64_t settled = 0;
  for (current = 0; current < buckets.size(); ++current) {
    for (size_t e = 0; e < buckets[current].size(); ++e) {
      if ((++settled & 0xffff) == 0 && stop.Reached()) {
        return absl::CancelledError("glide layer: stopped");
      }
      const GlideHeap::Entry top = buckets[current][e];
      if (top.alt > cells.Glide(top.index)) continue;  // stale
      RelaxNeighbours(nx, ny, climb, top.index, top.alt, cells, place);
    }
    buckets[current].clear();
    spare.push_back(std::move(buckets[current]));
  }
  *heap = std::move(overflow);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::vector<double>> ComputeGlideAltitude(int nx, int ny, double res,
                                                         const std::vector<float>& terrain,
                                                         const std::vector<uint8_t>& nofly,
                                                         const std::vector<LandingSite>& sites,
                                                         double glide_ratio, double clearance_m,
                                                         const StopCondition& stop,
                                                         const GlideWind& wind) {
  RISKPLAN_DCHECK(terrain.size() == static_cast<size_t>(nx) * static_cast<size_t>(ny));
  RISKPLAN_DCHECK(nofly.size() == terrain.size());
  RISKPLAN_DCHECK(glide_ratio > 0.0);
  const size_t cells = static_cast<size_t>(nx) * static_cast<size_t>(ny);
  std::vector<GlideCell> work(cells);
  for (size_t k = 0; k < cells; ++k) work[k] = {kInf, FloorOf(terrain, nofly, k, clearance_m)};

  GlideHeap heap;
  for (const LandingSite& site : sites) {
    if (site.i < 0 || site.j < 0 || site.i >= nx || site.j >= ny) continue;
    const size_t k = static_cast<size_t>(site.j) * nx + site.i;
    if (work[k].floor < work[k].glide) {  // false for no-fly cells and repeated sites
      work[k].glide = work[k].floor;
      heap.Push({work[k].floor, static_cast<uint32_t>(k)});
    }
  }
  double climb[8];
  GlideClimbs(res, glide_ratio, wind, climb);

  // First, buckets (Dial's algorithm): altitudes in buckets half the
  // smallest climb wide, settled bucket by bucket in any order within one.
  // A cell's label can only be lowered by a cell at least one climb below
  // it, two buckets or more earlier, already settled: so every label is
  // final when its bucket comes, and the result is the same unique fixed
  // point as the heap's, bit for bit, without the heap's log n per cell.
  // Labels more than kMaxBuckets buckets above the lowest site (a very
  // tall map for its climbs) are left to the heap.
  if (absl::Status s = SettleInBuckets(nx, ny, climb, stop, &work, &heap); !s.ok()) return s;
  PackedCells packed{work};
  if (absl::StatusOr<int64_t> s = SettleInHeap(nx, ny, climb, stop, packed, &heap); !s.ok()) {
    return s.status();
  }

  std::vector<double> glide(cells);
  for (size_t k = 0; k < cells; ++k) glide[k] = work[k].glide;
  return glide;
}

absl::Status RepairGlideAltitude(int nx, int ny, double res, const std::vector<float>& terrain,
                                 const std::vector<LandingSite>& sites, double glide_ratio,
                                 double clearance_m, const GlideWind& wind,
                                 const std::vector<uint8_t>& old_nofly,
                                 const std::vector<uint8_t>& new_nofly, std::vector<double>* glide,
                                 const StopCondition& stop, GlideRepairStats* stats) {
  const size_t cells = static_cast<size_t>(nx) * static_cast<size_t>(ny);
  RISKPLAN_DCHECK(terrain.size() == cells);
  RISKPLAN_DCHECK(old_nofly.size() == cells && new_nofly.size() == cells);
  RISKPLAN_DCHECK(glide->size() == cells);
  RISKPLAN_DCHECK(glide_ratio > 0.0);
  GlideRepairStats local;
  GlideRepairStats& st = stats != nullptr ? *stats : local;
  st = GlideRepairStats{};
  std::vector<double>& g = *glide;

  // The changed cells, compared eight at a time.
  std::vector<uint32_t> closed;
  std::vector<uint32_t> opened;
  {
    size_t k = 0;
    for (; k + 8 <= cells; k += 8) {
      uint64_t a = 0;
      uint64_t b = 0;
      std::memcpy(&a, old_nofly.data() + k, 8);
      std::memcpy(&b, new_nofly.data() + k, 8);
      if (a == b) continue;
      for (size_t m = k; m < k + 8; ++m) {
        if (old_nofly[m] == new_nofly[m]) continue;
        (new_nofly[m] != 0 ? closed : opened).push_back(static_cast<uint32_t>(m));
      }
    }
    for (; k < cells; ++k) {
      if (old_nofly[k] == new_nofly[k]) continue;
      (new_nofly[k] != 0 ? closed : opened).push_back(static_cast<uint32_t>(k));
    }
  }
  st.closed = static_cast<int64_t>(closed.size());
  st.opened = static_cast<int64_t>(opened.size());
  if (closed.empty() && opened.empty()) return absl::OkStatus();

  double climb[8];
  GlideClimbs(res, glide_ratio, wind, climb);
  std::vector<uint32_t> site_cells;
  for (const LandingSite& site : sites) {
    if (site.i < 0 || site.j < 0 || site.i >= nx || site.j >= ny) continue;
    site_cells.push_back(static_cast<uint32_t>(site.j) * static_cast<uint32_t>(nx) + site.i);
  }
  std::sort(site_cells.begin(), site_cells.end());
  const auto is_site = [&](uint32_t k) {
    return std::binary_search(site_cells.begin(), site_cells.end(), k);
  };
  LayerCells layer{g, terrain, new_nofly, clearance_m};
  const auto cell_of = [&](uint32_t k, int* i, int* j) {
    *i = static_cast<int>(k % static_cast<uint32_t>(nx));
    *j = static_cast<int>(k / static_cast<uint32_t>(nx));
  };

  // 1. The cells that lose their altitude, in increasing (old) altitude. A
  // cell's predecessors are the neighbours n whose step gives exactly its
  // label, GlideStep(floor, glide(n), climb) == glide(c); they lie strictly
  // below it. A cell is affected when it is no site and every predecessor is
  // closed or affected: so once the cells below it are decided, so is it.
  // Only the cells a closed or affected cell was a predecessor of are looked
  // at. Labels stay the old ones until every cell is decided.
  enum : uint8_t { kUndecided = 0, kQueued = 1, kLost = 2 };
  std::vector<uint8_t> state(cells, kUndecided);
  std::vector<uint32_t> lost;
  GlideHeap candidates;
  // Queues the open cells `k` was a predecessor of.
  const auto queue_successors = [&](uint32_t k) {
    const double alt = g[k];
    if (!std::isfinite(alt)) return;
    int ci = 0, cj = 0;
    cell_of(k, &ci, &cj);
    for (int d = 0; d < 8; ++d) {
      const int ni = ci + kDi[d];
      const int nj = cj + kDj[d];
      if (ni < 0 || nj < 0 || ni >= nx || nj >= ny) continue;
      const uint32_t nk = static_cast<uint32_t>(nj) * static_cast<uint32_t>(nx) + ni;
      if (state[nk] != kUndecided || new_nofly[nk] != 0 || !std::isfinite(g[nk])) continue;
      if (GlideStep(layer.Floor(nk), alt, climb[d]) != g[nk]) continue;
      state[nk] = kQueued;
      candidates.Push({g[nk], nk});
    }
  };
  for (uint32_t k : closed) {
    state[k] = kLost;
    queue_successors(k);
  }
  uint64_t looked = 0;
  while (!candidates.empty()) {
    if ((++looked & 0xffff) == 0 && stop.Reached()) {
      return absl::CancelledError("glide layer repair: stopped");
    }
    const uint32_t c = candidates.Top().index;
    candidates.Pop();
    const double alt = g[c];
    bool held = is_site(c);  // open, so its label is its floor
    if (!held) {
      int ci = 0, cj = 0;
      cell_of(c, &ci, &cj);
      const double floor = layer.Floor(c);
      for (int d = 0; d < 8 && !held; ++d) {
        // The predecessor n with c = n + (kDi[d], kDj[d]).
        const int ni = ci - kDi[d];
        const int nj = cj - kDj[d];
        if (ni < 0 || nj < 0 || ni >= nx || nj >= ny) continue;
        const uint32_t nk = static_cast<uint32_t>(nj) * static_cast<uint32_t>(nx) + ni;
        if (state[nk] == kLost || new_nofly[nk] != 0) continue;
        held = g[nk] < alt && GlideStep(floor, g[nk], climb[d]) == alt;
      }
    }
    if (held) continue;  // stays kQueued: decided, kept
    state[c] = kLost;
    lost.push_back(c);
    queue_successors(c);
  }
  st.affected = static_cast<int64_t>(lost.size());

  // 2. Reset them (and the closed cells), then seed every lost and every
  // reopened cell from its neighbours, as a relaxation from each of them
  // would; the other cells keep labels that are final (closing raises no
  // label they rest on) or upper bounds that a relaxation from a seed lowers.
  for (uint32_t k : closed) g[k] = kInf;
  for (uint32_t k : lost) g[k] = kInf;
  GlideHeap heap;
  const auto seed = [&](uint32_t c) {
    int ci = 0, cj = 0;
    cell_of(c, &ci, &cj);
    const double floor = layer.Floor(c);
    double best = is_site(c) ? floor : kInf;
    for (int d = 0; d < 8; ++d) {
      const int ni = ci - kDi[d];
      const int nj = cj - kDj[d];
      if (ni < 0 || nj < 0 || ni >= nx || nj >= ny) continue;
      const uint32_t nk = static_cast<uint32_t>(nj) * static_cast<uint32_t>(nx) + ni;
      if (!std::isfinite(g[nk])) continue;
      best = std::min(best, GlideStep(floor, g[nk], climb[d]));
    }
    if (best < g[c]) {
      g[c] = best;
      heap.Push({best, c});
    }
  };
  for (uint32_t k : lost) seed(k);
  for (uint32_t k : opened) seed(k);

  // 3. The same Dijkstra as the full computation, from the seeds.
  absl::StatusOr<int64_t> settled = SettleInHeap(nx, ny, climb, stop, layer, &heap);
  if (!settled.ok()) return settled.status();
  st.settled = *settled;
  return absl::OkStatus();
}

}  // namespace riskplan
