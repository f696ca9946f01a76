#include "geo/vector_input.h"

#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogrsf_frmts.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace riskplan::geo {
namespace {

// Points per side when the map's outline is carried into an input's CRS.
constexpr int kOutlinePoints = 64;

std::string FieldNames(OGRLayer& layer) {
  std::vector<std::string> names;
  OGRFeatureDefn* defn = layer.GetLayerDefn();
  for (int k = 0; k < defn->GetFieldCount(); ++k) {
    names.push_back(defn->GetFieldDefn(k)->GetNameRef());
  }
  return names.empty() ? "none" : absl::StrJoin(names, ", ");
}

// The index of `field` in the input's layer, or -1 for "" (no field asked).
absl::StatusOr<int> FieldIndex(const VectorInput& input, const std::string& field) {
  if (field.empty()) return -1;
  OGRLayer& layer = *input.ogr_layer;
  const int index = layer.GetLayerDefn()->GetFieldIndex(field.c_str());
  if (index < 0) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: no field '%s'; it has: %s",
                                                      input.Label(), field, FieldNames(layer)));
  }
  return index;
}

// Sets OGR's spatial filter to the envelope of the map's outline, grown by
// the margin, carried into the input's CRS.
absl::Status FilterToMap(VectorInput& input, const TargetGrid& grid, double margin_m) {
  OGRLayer& layer = *input.ogr_layer;
  auto frame = SpatialReferenceFrom(grid.frame.proj_definition());
  if (!frame.ok()) return frame.status();
  auto to_input = TransformationBetween(**frame, *input.srs);
  if (!to_input.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(input.Label(), ": ", to_input.status().message()));
  }
  const double x0 = grid.frame.x0() - margin_m, y0 = grid.frame.y0() - margin_m;
  const double x1 = grid.frame.x0() + grid.width_m() + margin_m;
  const double y1 = grid.frame.y0() + grid.height_m() + margin_m;
  // Points along every edge, not just the corners: in the input's CRS the
  // outline's edges are curves, and the envelope must hold all of them.
  std::vector<double> xs, ys;
  for (int k = 0; k <= kOutlinePoints; ++k) {
    const double t = static_cast<double>(k) / kOutlinePoints;
    for (auto [x, y] : {std::pair{x0 + t * (x1 - x0), y0},
                        {x0 + t * (x1 - x0), y1},
                        {x0, y0 + t * (y1 - y0)},
                        {x1, y0 + t * (y1 - y0)}}) {
      xs.push_back(x);
      ys.push_back(y);
    }
  }
  std::vector<int> ok(xs.size());
  (*to_input)->Transform(static_cast<int>(xs.size()), xs.data(), ys.data(), nullptr, ok.data());
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  for (size_t k = 0; k < xs.size(); ++k) {
    if (!ok[k] || !std::isfinite(xs[k]) || !std::isfinite(ys[k])) continue;
    min_x = std::min(min_x, xs[k]);
    max_x = std::max(max_x, xs[k]);
    min_y = std::min(min_y, ys[k]);
    max_y = std::max(max_y, ys[k]);
  }
  // When no outline point could be carried into the input's CRS, no filter
  // rather than a wrong one: every feature is read.
  if (min_x <= max_x && min_y <= max_y) {
    layer.SetSpatialFilterRect(min_x, min_y, max_x, max_y);
  } else {
    layer.SetSpatialFilter(nullptr);
  }
  return absl::OkStatus();
}

// The features that pass the layer's filters, with the fields at
// `number_index` and `text_index` (-1: none).
absl::StatusOr<std::vector<SourceFeature>> ReadFiltered(VectorInput& input, int number_index,
                                                        int text_index) {
  OGRLayer& layer = *input.ogr_layer;
  GdalErrorCapture errors;
  std::vector<SourceFeature> features;
  layer.ResetReading();
  for (auto& feature : layer) {
    if (static_cast<int64_t>(features.size()) >= kMaxFeaturesPerInput) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: more than %d features meet the map; clip the input to the area first (ogr2ogr "
          "-spat)",
          input.Label(), kMaxFeaturesPerInput));
    }
    const OGRGeometry* g = feature->GetGeometryRef();
    if (g == nullptr || g->IsEmpty()) continue;
    SourceFeature f;
    f.fid = feature->GetFID();
    f.geometry.reset(g->clone());
    if (number_index >= 0 && feature->IsFieldSetAndNotNull(number_index)) {
      f.number = feature->GetFieldAsDouble(number_index);
    }
    if (text_index >= 0 && feature->IsFieldSetAndNotNull(text_index)) {
      f.text = feature->GetFieldAsString(text_index);
    }
    features.push_back(std::move(f));
  }
  if (!errors.Errors("").empty()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: reading its features failed: %s", input.Label(), errors.Errors()));
  }
  return features;
}

}  // namespace

std::string VectorInput::Label() const {
  return absl::StrFormat("layer '%s', input '%s' (layer '%s')", layer, path, layer_name);
}

std::string VectorInput::Summary() const {
  std::string text = absl::StrFormat("%s, %s", driver, CrsShortName(srs.get()));
  if (!where.empty()) absl::StrAppend(&text, ", where ", where);
  return text;
}

absl::StatusOr<VectorInput> OpenVectorInput(const std::string& layer, const std::string& path,
                                            const std::string& layer_name,
                                            const std::string& where) {
  EnsureGdalRegistered();
  VectorInput in;
  in.layer = layer;
  in.path = path;
  in.where = where;
  const std::string label = absl::StrFormat("layer '%s', input '%s'", layer, path);
  if (IsRemotePath(path)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: not a local file; an import reads no network (download it first)", label));
  }
  if (absl::Status s = CheckReadable(label, path); !s.ok()) return s;
  GdalErrorCapture errors;
  in.dataset.reset(GDALDataset::Open(path.c_str(),
                                     GDAL_OF_VECTOR | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR));
  if (in.dataset == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: GDAL cannot open it as a vector source: %s", label, errors.Errors()));
  }
  in.driver = in.dataset->GetDriver() != nullptr ? in.dataset->GetDriver()->GetDescription() : "";
  if (in.dataset->GetLayerCount() < 1) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: it holds no layer", label));
  }
  std::string name = layer_name;
  // The OSM driver's first layer is its points; building footprints are in
  // "multipolygons" (docs/geodata.md, "OpenStreetMap buildings").
  if (name.empty() && in.driver == "OSM" && layer == "buildings") name = "multipolygons";
  if (name.empty()) {
    in.ogr_layer = in.dataset->GetLayer(0);
  } else {
    in.ogr_layer = in.dataset->GetLayerByName(name.c_str());
    if (in.ogr_layer == nullptr) {
      std::vector<std::string> names;
      for (OGRLayer* l : in.dataset->GetLayers()) names.push_back(l->GetName());
      return absl::InvalidArgumentError(absl::StrFormat("%s: no layer '%s'; it has: %s", label,
                                                        name, absl::StrJoin(names, ", ")));
    }
  }
  in.layer_name = in.ogr_layer->GetName();
  const OGRSpatialReference* srs = in.ogr_layer->GetSpatialRef();
  if (srs == nullptr || srs->IsEmpty()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: the layer has no CRS (a shapefile needs its .prj); assign one, e.g. ogr2ogr -a_srs "
        "EPSG:XXXX",
        in.Label()));
  }
  in.srs = GisOrderCopy(*srs);  // longitude first, as the geometries hold it
  if (!where.empty() && in.ogr_layer->SetAttributeFilter(where.c_str()) != OGRERR_NONE) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: OGR refuses the filter '%s': %s", in.Label(), where, errors.Errors()));
  }
  return in;
}

absl::StatusOr<CoordinateTransformationPtr> ToFrame(const OGRSpatialReference& from,
                                                    const TargetGrid& grid) {
  auto frame = SpatialReferenceFrom(grid.frame.proj_definition());
  if (!frame.ok()) return frame.status();
  return TransformationBetween(from, **frame);
}

absl::StatusOr<std::vector<SourceFeature>> ReadFeatures(VectorInput& input, const TargetGrid& grid,
                                                        double margin_m,
                                                        const std::string& number_field,
                                                        const std::string& text_field) {
  int number_index = -1, text_index = -1;
  for (auto [field, index] :
       {std::pair{&number_field, &number_index}, {&text_field, &text_index}}) {
    auto found = FieldIndex(input, *field);
    if (!found.ok()) return found.status();
    *index = *found;
  }
  if (absl::Status s = FilterToMap(input, grid, margin_m); !s.ok()) return s;
  return ReadFiltered(input, number_index, text_index);
}

double VerticesAddedBySegmentize(const OGRGeometry& geometry, double max_length) {
  const OGRwkbGeometryType type = wkbFlatten(geometry.getGeometryType());
  double added = 0.0;
  if (OGR_GT_IsSubClassOf(type, wkbGeometryCollection)) {
    const OGRGeometryCollection* c = geometry.toGeometryCollection();
    for (int k = 0; k < c->getNumGeometries(); ++k) {
      added += VerticesAddedBySegmentize(*c->getGeometryRef(k), max_length);
    }
  } else if (OGR_GT_IsSubClassOf(type, wkbCurvePolygon)) {
    const OGRCurvePolygon* p = geometry.toCurvePolygon();
    if (p->getExteriorRingCurve() != nullptr) {
      added += VerticesAddedBySegmentize(*p->getExteriorRingCurve(), max_length);
    }
    for (int k = 0; k < p->getNumInteriorRings(); ++k) {
      added += VerticesAddedBySegmentize(*p->getInteriorRingCurve(k), max_length);
    }
  } else if (type == wkbCompoundCurve) {
    const OGRCompoundCurve* c = geometry.toCompoundCurve();
    for (int k = 0; k < c->getNumCurves(); ++k) {
      added += VerticesAddedBySegmentize(*c->getCurve(k), max_length);
    }
  } else if (const auto* curve = dynamic_cast<const OGRSimpleCurve*>(&geometry)) {
    // Line strings, linear rings and circular strings.
    for (int k = 1; k < curve->getNumPoints(); ++k) {
      const double length = std::hypot(curve->getX(k) - curve->getX(k - 1),
                                       curve->getY(k) - curve->getY(k - 1));
      if (!std::isfinite(length)) return std::numeric_limits<double>::infinity();
      added += std::max(0.0, std::ceil(length / max_length) - 1.0);
    }
  }
  // Points and polyhedral surfaces: segmentize adds nothing.
  return added;
}

absl::StatusOr<std::unique_ptr<OGRGeometry>> Carry(const OGRGeometry& geometry,
                                                   const OGRSpatialReference& from,
                                                   OGRCoordinateTransformation& ct,
                                                   CarryBudget& budget) {
  std::unique_ptr<OGRGeometry> g(geometry.clone());
  const OGRwkbGeometryType type = wkbFlatten(g->getGeometryType());
  if (type != wkbPoint && type != wkbMultiPoint) {
    // Straight edges are cut into pieces of at most 100 m (0.001 degrees in a
    // geographic CRS) so that they stay straight in the map's frame; the
    // vertices that adds are counted against the budget first.
    const bool geographic = IsGeographic(from);
    const double step = geographic ? 0.001 : 100.0;
    const double added = VerticesAddedBySegmentize(*g, step);
    if (!(added <= budget.added_vertices_left)) {
      OGREnvelope e;
      g->getEnvelope(&e);
      return absl::InvalidArgumentError(absl::StrFormat(
          "cutting its edges into pieces of at most %s for the change of CRS would add %.4g "
          "vertices, more than the %.0f left of the %d the importer allows one input's features; "
          "its envelope is x %.9g to %.9g, y %.9g to %.9g in the input's CRS: check its "
          "coordinates, or clip the input to the map's area first (ogr2ogr -clipsrc)",
          geographic ? "0.001 degrees" : "100 m", added, budget.added_vertices_left,
          kMaxAddedVerticesPerInput, e.MinX, e.MaxX, e.MinY, e.MaxY));
    }
    budget.added_vertices_left -= added;
    g->segmentize(step);
  }
  GdalErrorCapture errors;
  if (g->transform(&ct) != OGRERR_NONE) {
    return absl::InvalidArgumentError(
        absl::StrFormat("PROJ cannot carry it into the map's frame: %s", errors.Errors()));
  }
  return g;
}

absl::StatusOr<SpatialReferencePtr> EqualAreaFrame(const TargetGrid& grid) {
  const LatLon c = grid.Center();
  return SpatialReferenceFrom(absl::StrFormat(
      "+proj=laea +lat_0=%.17g +lon_0=%.17g +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs +type=crs",
      c.lat_deg, c.lon_deg));
}

}  // namespace riskplan::geo
