#include "core/flight/trajectory_io.h"

#include <fstream>
#include <sstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "nlohmann/json.hpp"

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

absl::StatusOr<TrajectoryInput> ParseTrajectoryJson(std::string_view json) {
  nlohmann::json doc = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return absl::InvalidArgumentError("trajectory file: not a JSON object");
  }
  const bool has_waypoints = doc.contains("waypoints");
  const bool has_polyline = doc.contains("polyline");
  if (has_waypoints == has_polyline) {
    return absl::InvalidArgumentError(
        "trajectory file: exactly one of \"waypoints\" and \"polyline\" must be given");
  }
  const char* key = has_waypoints ? "waypoints" : "polyline";
  const size_t arity = has_waypoints ? 4 : 3;
  const nlohmann::json& list = doc[key];
  if (!list.is_array()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("trajectory file: \"%s\" must be a list", key));
  }
  TrajectoryInput out;
  for (size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& item = list[i];
    if (!item.is_array() || item.size() != arity) {
      return absl::InvalidArgumentError(
          absl::StrFormat("trajectory file: %s[%d] must be a list of %d numbers", key, i, arity));
    }
    double v[4] = {0, 0, 0, 0};
    for (size_t k = 0; k < arity; ++k) {
      if (!item[k].is_number()) {
        return absl::InvalidArgumentError(
            absl::StrFormat("trajectory file: %s[%d][%d] is not a number", key, i, k));
      }
      v[k] = item[k].get<double>();
    }
    if (has_waypoints) {
      out.waypoints.push_back(Pose{v[0], v[1], v[2], v[3]});
    } else {
      out.polyline.push_back(Point3{v[0], v[1], v[2]});
    }
  }
  return out;
}

absl::StatusOr<TrajectoryInput> ReadTrajectoryFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrFormat("cannot open trajectory file '%s'", path));
  std::stringstream buffer;
  buffer << in.rdbuf();
  auto parsed = ParseTrajectoryJson(buffer.str());
  if (!parsed.ok()) {
    return absl::Status(parsed.status().code(),
                        absl::StrFormat("%s: %s", path, parsed.status().message()));
  }
  return parsed;
}

}  // namespace riskplan
