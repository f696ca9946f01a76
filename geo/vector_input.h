// Vector inputs of an import (census polygons, building footprints, no-fly
// zones, landing sites): opened with OGR, filtered to the map, and carried
// into other CRSs.
#ifndef RISKPLAN_GEO_VECTOR_INPUT_H_
#define RISKPLAN_GEO_VECTOR_INPUT_H_

#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogrsf_frmts.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "geo/gdal_util.h"
#include "geo/target_grid.h"

namespace riskplan::geo {

// At most this many features are read from one input (bounded work): a city's
// buildings are some 10^5 to 10^6.
inline constexpr int64_t kMaxFeaturesPerInput = 20'000'000;

// At most this many vertices may Carry's cutting of edges add to the features
// of one input (16 to 24 bytes each, in one array per ring). Real inputs add
// few: a building's edges are shorter than the pieces, and the outline of a
// census district that meets the map some thousands. One wrong coordinate (a
// latitude of 5919 degrees, an easting of 1e12 m) would make a single edge of
// millions or billions of pieces.
inline constexpr int64_t kMaxAddedVerticesPerInput = 4'000'000;

// What is left of one input's kMaxAddedVerticesPerInput: one per input,
// passed to every Carry of its features.
struct CarryBudget {
  double added_vertices_left = static_cast<double>(kMaxAddedVerticesPerInput);
};

// One open vector input. `layer` names the map layer it feeds ("population",
// "buildings", "no-fly", "landing sites"), for messages.
struct VectorInput {
  std::string layer;
  std::string path;
  GDALDatasetUniquePtr dataset;
  OGRLayer* ogr_layer = nullptr;  // owned by dataset
  std::string layer_name;
  std::string where;        // the attribute filter, or ""
  SpatialReferencePtr srs;  // GIS order; never null once opened
  std::string driver;

  // "layer 'no-fly', input 'zones.gpkg' (layer 'airports')"
  std::string Label() const;
  // "GPKG, EPSG:4326, where building IS NOT NULL"
  std::string Summary() const;
};

// Opens `path` as a vector source for `layer`: the OGR layer named
// `layer_name` or, when empty, the default (for an OpenStreetMap file with
// layer 'buildings': 'multipolygons'; otherwise the first layer), with the
// attribute filter `where` (OGR SQL, e.g. "building IS NOT NULL"; "" for
// none). Refusals (InvalidArgument, naming layer and input): not openable as
// a vector source, not a local file, no such layer (the message lists the
// layers), a bad filter, no CRS (a shapefile without .prj: GeoJSON is always
// WGS84).
absl::StatusOr<VectorInput> OpenVectorInput(const std::string& layer, const std::string& path,
                                            const std::string& layer_name,
                                            const std::string& where);

// A feature of an input: its geometry in the input's CRS and what was asked
// of its attributes.
struct SourceFeature {
  int64_t fid = 0;
  std::unique_ptr<OGRGeometry> geometry;
  std::optional<double> number;  // the numeric field asked for, when set and not null
  std::string text;              // the text field asked for, or ""
};

// The features of `input` whose envelope meets the map's area grown by
// margin_m on every side (OGR's spatial filter, in the input's CRS), with the
// numeric field `number_field` and the text field `text_field` (each "" for
// none). Features without geometry are skipped. InvalidArgument names the
// input: a field it does not have (listing those it has), more than
// kMaxFeaturesPerInput features.
absl::StatusOr<std::vector<SourceFeature>> ReadFeatures(VectorInput& input, const TargetGrid& grid,
                                                        double margin_m,
                                                        const std::string& number_field,
                                                        const std::string& text_field);

// The transformation from the input's CRS to the grid's local frame.
absl::StatusOr<CoordinateTransformationPtr> ToFrame(const OGRSpatialReference& from,
                                                    const TargetGrid& grid);

// A copy of `geometry` carried through `ct`. Its straight edges are first
// cut into pieces of at most 100 m (0.001 deg in a geographic CRS), so an
// edge that is straight in the input's CRS stays so after the change of CRS;
// the vertices that adds are counted against `budget` before any is made.
// InvalidArgument if they would exceed what is left of it (naming the count,
// the limit and the geometry's envelope) or if PROJ cannot carry a point.
absl::StatusOr<std::unique_ptr<OGRGeometry>> Carry(const OGRGeometry& geometry,
                                                   const OGRSpatialReference& from,
                                                   OGRCoordinateTransformation& ct,
                                                   CarryBudget& budget);

// How many vertices OGRGeometry::segmentize(max_length) adds to `geometry`
// (an upper bound: ceil(length / max_length) - 1 per edge, arcs counted by
// their chords), as a double so that no count overflows; +infinity when a
// coordinate is not finite.
double VerticesAddedBySegmentize(const OGRGeometry& geometry, double max_length);

// An equal-area frame for the map (Lambert azimuthal equal-area on WGS84 at
// the map's centre), where areas of polygons far beyond the map, such as
// whole census districts, are exact.
absl::StatusOr<SpatialReferencePtr> EqualAreaFrame(const TargetGrid& grid);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_VECTOR_INPUT_H_
