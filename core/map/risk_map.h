// RiskMap: one city's immutable raster layers, as the risk model reads them.
//
// Grid (spec "Frames and units"): origin (x0, y0) at the south-west corner,
// square cells of side res metres, nx columns (east) by ny rows (north).
// Cell (i, j) covers [x0 + i*res, x0 + (i+1)*res) x [y0 + j*res, y0 + (j+1)*res).
// Layers are stored row-major with row j = 0 the southernmost:
// index = j * nx + i.
//
// A RiskMap is created once (from a bundle on disk or from a generator), fully
// validated, and then shared read-only between threads: every const method is
// thread-safe.
#ifndef RISKPLAN_CORE_MAP_RISK_MAP_H_
#define RISKPLAN_CORE_MAP_RISK_MAP_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/check.h"

namespace riskplan {

// A cell where the aircraft may land in an emergency.
struct LandingSite {
  std::string name;  // may be empty
  int i = 0;         // column
  int j = 0;         // row
};

// Optional geo-reference of the local frame (informational: the risk model
// never uses it).
struct GeoReference {
  double origin_lat_deg = 0.0;  // WGS84 latitude of (x0, y0)
  double origin_lon_deg = 0.0;  // WGS84 longitude of (x0, y0)
  std::string crs;              // free text, e.g. "local ENU tangent plane"
};

struct MapHeader {
  std::string name;  // [a-z0-9-_.], 1..64 characters
  double x0 = 0.0;   // m, south-west corner, east coordinate
  double y0 = 0.0;   // m, south-west corner, north coordinate
  double res = 5.0;  // m, cell side, > 0
  int nx = 0;        // columns, > 0
  int ny = 0;        // rows, > 0
  std::optional<GeoReference> geo;
  std::string provenance;  // who made the data and how (free text)
};

// The raw layers of a map before validation. Every vector has nx*ny entries.
struct MapLayers {
  std::vector<float> density;  // rho, people per m^2, >= 0 and finite
  std::vector<float> shelter;  // S, [0, 10]
  std::vector<float> terrain;  // T, m AMSL, finite
  std::vector<uint8_t> nofly;  // Z, 0 or 1
  std::vector<LandingSite> landing_sites;
};

// Largest map riskplan accepts: nx*ny <= kMaxMapCells (64 Mi cells: 256 MiB
// per float layer), and each side <= kMaxMapSide so that the padded layers of a
// long, thin map stay within a few percent of the unpadded size.
inline constexpr int64_t kMaxMapCells = int64_t{64} * 1024 * 1024;
inline constexpr int kMaxMapSide = 65536;

// Checks a header alone: name of 1 to 64 characters of [a-z0-9._-], res > 0
// and finite, x0 and y0 finite, nx and ny in [1, kMaxMapSide], nx*ny <=
// kMaxMapCells. Returns InvalidArgument naming the field and its value, e.g.
//   "map header: res has value 0; res must be > 0 and finite".
// RiskMap::Create() calls it; loaders call it first so that they never size a
// buffer from an unchecked header.
absl::Status ValidateMapHeader(const MapHeader& header);

// How much work a RepairGlideAltitude() did.
struct GlideRepairStats {
  int64_t closed = 0;    // cells open before, no-fly now
  int64_t opened = 0;    // cells no-fly before, open now
  int64_t affected = 0;  // open cells whose every glide path ran through a closed cell
  int64_t settled = 0;   // cells the restricted Dijkstra settled
};
class RiskMap {
 public:
  // Width of the border of padding around the padded density and shelter
  // layers: the largest kernel half-width riskplan accepts (spec hw_max <= 31
  // by default; ModelParams may not exceed kMaxHalfWidth).
  static constexpr int kPad = 63;

  // Validates header and layers against the spec's domains and builds the map,
  // including the glide-altitude layer (spec section 6) for the given glide ratio
  // and clearance. Errors are InvalidArgument and name the layer, the cell (i, j)
  // and the offending value, e.g.
  //   "layer 'density': cell (12, 40) has value -0.5; density must be >= 0 and finite".
  // Checks, in this order (the first failure is returned; within a layer the
  // first bad cell in index order, i.e. southernmost row first, is named):
  //   ValidateMapHeader(header);
  //   "glide_ratio has value V; glide_ratio must be > 0 and finite"
  //   "glide_clearance_m has value V; glide_clearance_m must be >= 0 and finite"
  //   "layer 'L' has N entries; expected nx*ny = M"  (density, shelter, terrain, nofly)
  //   "layer 'density': cell (i, j) has value V; density must be >= 0 and finite"
  //   "layer 'shelter': cell (i, j) has value V; shelter must be in [0, 10] and finite"
  //   "layer 'terrain': cell (i, j) has value V; terrain must be finite"
  //   "layer 'nofly': cell (i, j) has value V; nofly must be 0 or 1"
  //   "layer 'landing_sites': site 'NAME' at cell (i, j) is outside the map of NX x NY cells"
  // Values print with printf's %.9g ("nan", "inf", "-0.5", "11").
  static absl::StatusOr<std::shared_ptr<const RiskMap>> Create(MapHeader header, MapLayers layers,
                                                               double glide_ratio = 10.0,
                                                               double glide_clearance_m = 10.0);

  const MapHeader& header() const { return header_; }
  const std::string& name() const { return header_.name; }
  int nx() const { return header_.nx; }
  int ny() const { return header_.ny; }
  double res() const { return header_.res; }
  double x0() const { return header_.x0; }
  double y0() const { return header_.y0; }
  double width_m() const { return header_.nx * header_.res; }
  double height_m() const { return header_.ny * header_.res; }

  // cell(x, y) = (floor((x - x0)/res), floor((y - y0)/res)). Returns false, and
  // leaves *i, *j untouched, when (x, y) is outside the map or not finite.
  bool CellOf(double x, double y, int* i, int* j) const;
  bool Contains(int i, int j) const { return i >= 0 && j >= 0 && i < nx() && j < ny(); }
  int64_t Index(int i, int j) const { return static_cast<int64_t>(j) * nx() + i; }

  // Layer values of an in-map cell. REQUIRES: Contains(i, j).
  float density(int i, int j) const {
    RISKPLAN_DCHECK(Contains(i, j));
    return density_[Index(i, j)];
  }
  float shelter(int i, int j) const {
    RISKPLAN_DCHECK(Contains(i, j));
    return shelter_[Index(i, j)];
  }
  float terrain(int i, int j) const {
    RISKPLAN_DCHECK(Contains(i, j));
    return terrain_[Index(i, j)];
  }
  bool nofly(int i, int j) const {
    RISKPLAN_DCHECK(Contains(i, j));
    return nofly_[Index(i, j)] != 0;
  }
  // The layers the map was created with. A map made by WithNoFly() shares
  // them with its base, and its no-fly layer is nofly_layer(), not
  // layers().nofly (its base's): read the no-fly cells through nofly() or
  // nofly_layer().
  const MapLayers& layers() const { return shared_->layers; }
  // The no-fly layer of this map (nx*ny entries, 0 or 1).
  const std::vector<uint8_t>& nofly_layer() const { return *nofly_layer_; }
  // The lowest and highest terrain of the map, m AMSL (computed once).
  double terrain_min_m() const { return shared_->terrain_min_m; }
  double terrain_max_m() const { return shared_->terrain_max_m; }
  const std::vector<LandingSite>& landing_sites() const { return shared_->layers.landing_sites; }

  // A map with the header, density, shelter, terrain and landing sites of
  // `base`, shared rather than copied, and `nofly` (nx*ny entries, each 0 or
  // 1) as its no-fly layer: an in-flight session's map with its temporary
  // zones closed. Its glide layer is `base`'s repaired by
  // RepairGlideAltitude (the same layer as ComputeGlideAltitude of `nofly`,
  // bit for bit), so it costs what the cells whose glide altitude changes
  // cost, not a map's Dijkstra; `stats`, when given, says how many. Errors
  // name the layer as Create() does ("layer 'nofly' has N entries; ...",
  // "layer 'nofly': cell (i, j) has value V; nofly must be 0 or 1"), and
  // Cancelled once `stop` is reached.
  static absl::StatusOr<std::shared_ptr<const RiskMap>> WithNoFly(
      const std::shared_ptr<const RiskMap>& base, std::vector<uint8_t> nofly,
      const StopCondition& stop = StopCondition(), GlideRepairStats* stats = nullptr);
  // True when both maps hold the same density, shelter and terrain layers
  // and landing sites (one made from the other by WithNoFly(), or both from
  // the same map): they differ at most in their no-fly cells.
  bool SharesLayersWith(const RiskMap& other) const { return shared_ == other.shared_; }

  // Density and shelter with a border of kPad cells on every side (density 0,
  // shelter 10, as version 1 of the spec read unknown ground), so that the
  // EWMM loops read whole vectors of a row without bounds checks. Since
  // version 2 no kernel weighs a padding cell: windows lie wholly inside the
  // map (RiskModel::Locate), and only the zero weights that round a row up to
  // whole vectors fall on the padding. Row-major, stride padded_nx(); in-map cell
  // (i, j) is at PaddedIndex(i, j).
  int padded_nx() const { return header_.nx + 2 * kPad; }
  int padded_ny() const { return header_.ny + 2 * kPad; }
  int64_t PaddedIndex(int i, int j) const {
    return static_cast<int64_t>(j + kPad) * padded_nx() + (i + kPad);
  }
  const float* padded_density() const { return shared_->padded_density.data(); }
  const float* padded_shelter() const { return shared_->padded_shelter.data(); }

  // Glide altitude of spec section 6 (m AMSL) for the glide ratio and clearance
  // the map was created with; +infinity where no landing site can be reached
  // (and everywhere when the map has no landing sites, where safe altitude is
  // terrain + min_agl alone). See SafeAltitude().
  const std::vector<double>& glide_altitude() const { return *glide_altitude_; }
  // The same layer, to share it beyond the map's lifetime.
  const std::shared_ptr<const std::vector<double>>& glide_altitude_ptr() const {
    return glide_altitude_;
  }
  double glide_ratio() const { return glide_ratio_; }
  double glide_clearance_m() const { return glide_clearance_m_; }

  // safe_alt(c) of spec section 6 with the map's own glide layer.
  // REQUIRES: Contains(i, j).
  double SafeAltitude(int i, int j, double min_agl_m) const;

  // Bytes held by the layers (for metrics and the memory budget), those
  // shared with other maps (WithNoFly) included.
  size_t MemoryBytes() const;

 private:
  RiskMap() = default;

  // What maps made by WithNoFly() share with their base.
  struct Shared {
    MapLayers layers;
    std::vector<float> padded_density;
    std::vector<float> padded_shelter;
    double terrain_min_m = 0.0;
    double terrain_max_m = 0.0;
  };

  MapHeader header_;
  std::shared_ptr<const Shared> shared_;
  // shared_->layers.nofly, or a layer of the map's own (WithNoFly).
  std::shared_ptr<const std::vector<uint8_t>> nofly_layer_;
  std::shared_ptr<const std::vector<double>> glide_altitude_;
  // The layers' data, read by the accessors above.
  const float* density_ = nullptr;
  const float* shelter_ = nullptr;
  const float* terrain_ = nullptr;
  const uint8_t* nofly_ = nullptr;
  double glide_ratio_ = 10.0;
  double glide_clearance_m_ = 10.0;
};

// Computes the glide-altitude layer of spec section 6: Dijkstra over the
// 8-connected grid from every landing site, edges of length res or res*sqrt(2),
//   glide(site) = T(site) + clearance,
//   glide(c) = min over neighbours n of max(T(c) + clearance, glide(n) + dist(c, n)/G(c->n)),
// with G(c->n) the glide ratio over the ground of a glide from c towards n in
// `wind` (G in still air; an edge no crab angle holds, or whose ground speed
// is not positive, is not glided: spec version 3, section 6).
// No-fly cells are neither entered nor crossed by a glide (their glide altitude
// is +infinity, as is that of every cell no site can be reached from; a landing
// site in a no-fly cell is ignored). With no landing sites every cell is
// +infinity (callers then use terrain + min_agl alone). A diagonal step only
// touches the two cells beside it at a corner, so it is allowed even when they
// are no-fly. Sites outside the grid are skipped (Create() refuses them).
// Deterministic: the result is the unique fixed point of the recurrence, so it
// does not depend on the order in which equal altitudes are settled. Runs in
// O(n) with buckets half the smallest climb wide, a binary heap for labels beyond
// 2^20 buckets (docs/risk-model.md, "Glide altitude").
// REQUIRES: terrain and nofly hold nx*ny entries, glide_ratio > 0.
std::vector<double> ComputeGlideAltitude(int nx, int ny, double res,
                                         const std::vector<float>& terrain,
                                         const std::vector<uint8_t>& nofly,
                                         const std::vector<LandingSite>& sites, double glide_ratio,
                                         double clearance_m);
// The wind of a glide (spec version 3, section 6): the wind vector (where the
// air moves to) and the glide's airspeed v_g. The default is still air.
struct GlideWind {
  double x = 0.0;
  double y = 0.0;
  double airspeed_mps = 0.0;  // v_g; unused in still air
  bool Calm() const { return x == 0.0 && y == 0.0; }
};

// The same, polling `stop` every few milliseconds: Cancelled once it is
// reached (a request's glide parameters make a layer of their own, and a
// server that drains stops building it).
absl::StatusOr<std::vector<double>> ComputeGlideAltitude(int nx, int ny, double res,
                                                         const std::vector<float>& terrain,
                                                         const std::vector<uint8_t>& nofly,
                                                         const std::vector<LandingSite>& sites,
                                                         double glide_ratio, double clearance_m,
                                                         const StopCondition& stop,
                                                         const GlideWind& wind = {});

// Repairs a glide layer for a change of the no-fly layer: `*glide` holds
// ComputeGlideAltitude(..., old_nofly, ...) on entry and, on success,
// ComputeGlideAltitude(..., new_nofly, ...) on return, bit for bit (the
// same parameters otherwise), at the cost of the cells the change reaches.
// Closing cells can only raise glide altitudes: the open cells whose every
// shortest glide ran through a newly closed cell (found in increasing
// altitude, the neighbours that give a cell its altitude being its
// predecessors) are reset, seeded from their other neighbours, and settled
// again by the same relaxation. Opening cells can only lower them: the
// reopened cells are seeded from their neighbours and the relaxation spreads
// from them as far as it lowers anything. Both at once are one Dijkstra.
// On error (Cancelled once `stop` is reached) *glide is unspecified.
// REQUIRES: terrain, both no-fly layers and *glide hold nx*ny entries,
// glide_ratio > 0.
absl::Status RepairGlideAltitude(int nx, int ny, double res, const std::vector<float>& terrain,
                                 const std::vector<LandingSite>& sites, double glide_ratio,
                                 double clearance_m, const GlideWind& wind,
                                 const std::vector<uint8_t>& old_nofly,
                                 const std::vector<uint8_t>& new_nofly, std::vector<double>* glide,
                                 const StopCondition& stop = StopCondition(),
                                 GlideRepairStats* stats = nullptr);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_MAP_RISK_MAP_H_
