#include "core/flight/trajectory_io.h"

#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "formats/trajectory_json.h"

namespace riskplan {
namespace {

// Debian's abseil is built with its own absl::string_view (not an alias of
// std::string_view), so text crosses into abseil as absl::string_view.
absl::StatusOr<std::vector<std::vector<double>>> ParseTuples(absl::string_view text, size_t arity,
                                                             const char* what) {
  std::vector<std::vector<double>> out;
  size_t index = 0;
  for (absl::string_view item : absl::StrSplit(text, ';', absl::SkipWhitespace())) {
    std::vector<double> values;
    for (absl::string_view field : absl::StrSplit(item, ',')) {
      double v = 0.0;
      if (!absl::SimpleAtod(absl::StripAsciiWhitespace(field), &v)) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s[%d]: '%s' is not a number", what, index,
                            std::string(absl::StripAsciiWhitespace(field))));
      }
      values.push_back(v);
    }
    if (values.size() != arity) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s[%d]: '%s' has %d values; expected %d", what, index,
                          std::string(absl::StripAsciiWhitespace(item)), values.size(), arity));
    }
    out.push_back(std::move(values));
    ++index;
  }
  return out;
}

}  // namespace

absl::StatusOr<std::vector<Pose>> ParseWaypoints(std::string_view text) {
  auto tuples = ParseTuples(absl::string_view(text.data(), text.size()), 4, "waypoints");
  if (!tuples.ok()) return tuples.status();
  std::vector<Pose> out;
  for (const auto& t : *tuples) out.push_back(Pose{t[0], t[1], t[2], t[3]});
  return out;
}

absl::StatusOr<std::vector<Point3>> ParsePolyline(std::string_view text) {
  auto tuples = ParseTuples(absl::string_view(text.data(), text.size()), 3, "polyline");
  if (!tuples.ok()) return tuples.status();
  std::vector<Point3> out;
  for (const auto& t : *tuples) out.push_back(Point3{t[0], t[1], t[2]});
  return out;
}

namespace {

// Core's types for the points of the shared rule (formats/trajectory_json.h).
absl::StatusOr<TrajectoryInput> FromJson(absl::StatusOr<formats::TrajectoryJson> json) {
  if (!json.ok()) return json.status();
  TrajectoryInput out;
  if (json->is_polyline) {
    out.polyline.reserve(json->points.size());
    for (const auto& p : json->points) out.polyline.push_back(Point3{p[0], p[1], p[2]});
  } else {
    out.waypoints.reserve(json->points.size());
    for (const auto& p : json->points) out.waypoints.push_back(Pose{p[0], p[1], p[2], p[3]});
  }
  return out;
}

}  // namespace

absl::StatusOr<TrajectoryInput> ParseTrajectoryJson(std::string_view json) {
  return FromJson(formats::ParseTrajectoryJson(json));
}

absl::StatusOr<TrajectoryInput> ReadTrajectoryFile(const std::string& path) {
  return FromJson(formats::ReadTrajectoryFile(path));
}

}  // namespace riskplan
