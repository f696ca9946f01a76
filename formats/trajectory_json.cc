#include "formats/trajectory_json.h"

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <span>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "nlohmann/json.hpp"

namespace riskplan::formats {
namespace {

using Json = nlohmann::json;

constexpr const char* kWaypointFields[] = {"x", "y", "z", "theta"};
constexpr const char* kPolylineFields[] = {"x", "y", "z"};
static_assert(std::size(kWaypointFields) == 4 && std::size(kPolylineFields) == 3);

// A JSON string or scalar as it would be written, in ASCII (so that cutting it
// cannot split a UTF-8 sequence) and cut to 40 characters: an error message
// shows enough of the value to find it, not a whole file.
std::string Shown(const Json& value) {
  std::string text = value.dump(-1, ' ', /*ensure_ascii=*/true);
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

// "got object", "got string \"1.57\"", "got boolean true": the JSON type
// found, and the value too when it is short enough to help.
std::string Got(const Json& value) {
  if (value.is_string() || value.is_boolean()) {
    return absl::StrFormat("got %s %s", value.type_name(), Shown(value));
  }
  return absl::StrFormat("got %s", value.type_name());
}

std::string Plural(size_t n, const char* word) {
  return absl::StrFormat("%d %s%s", n, word, n == 1 ? "" : "s");
}

// The steps below return InvalidArgument with what is wrong; ParseJson puts
// the text's name in front.

// The document of `json`, which must be an object without a repeated key.
absl::StatusOr<Json> ParseObject(std::string_view json) {
  // nlohmann::json keeps only the last value of a repeated key, so a second
  // "waypoints" would silently replace the first: repeats are caught here,
  // while parsing. Depth 1 is the top-level object, the only one the rule
  // allows.
  std::set<std::string> keys;
  std::string repeated;
  Json doc;
  try {
    doc = Json::parse(json.begin(), json.end(),
                      [&](int depth, Json::parse_event_t event, Json& parsed) {
                        if (event == Json::parse_event_t::key && depth == 1 &&
                            !keys.insert(parsed.get<std::string>()).second && repeated.empty()) {
                          repeated = parsed.get<std::string>();
                        }
                        return true;
                      });
  } catch (const Json::exception& e) {
    // Only the exception carries the line and column of a syntax error; it is
    // caught right here. nlohmann's "[json.exception.parse_error.101] " tag
    // means nothing to a user and is dropped.
    std::string what = e.what();
    if (size_t close = what.find("] ");
        what.rfind("[json.exception", 0) == 0 && close != std::string::npos) {
      what = what.substr(close + 2);
    }
    return absl::InvalidArgumentError("not valid JSON: " + what);
  }
  if (!doc.is_object()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the top level must be an object, %s", Got(doc)));
  }
  if (!repeated.empty()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("key %s appears twice", Shown(Json(repeated))));
  }
  return doc;
}

// Whether the object holds a polyline (else waypoints): exactly one of the
// two keys, and no other.
absl::StatusOr<bool> IsPolyline(const Json& doc) {
  // Unknown keys are refused rather than ignored: a key such as "units" or
  // "frame" that this reader does not know could change what the numbers
  // mean, and a misspelt key would otherwise go unnoticed.
  for (const auto& [key, value] : doc.items()) {
    if (key != "waypoints" && key != "polyline") {
      return absl::InvalidArgumentError(absl::StrFormat(
          "unknown key %s; the only keys are \"waypoints\" and \"polyline\"", Shown(Json(key))));
    }
  }
  const bool has_waypoints = doc.contains("waypoints");
  const bool has_polyline = doc.contains("polyline");
  if (has_waypoints == has_polyline) {
    return absl::InvalidArgumentError(
        absl::StrFormat("needs exactly one of \"waypoints\" and \"polyline\", got %s",
                        has_waypoints ? "both" : "neither"));
  }
  return has_polyline;
}

// The points of `list`, the value of `key`: an array of 2 to
// kMaxTrajectoryJsonPoints arrays of `fields.size()` numbers.
absl::StatusOr<std::vector<std::array<double, 4>>> ReadPoints(const Json& list, const char* key,
                                                              std::span<const char* const> fields) {
  const std::string shape = absl::StrFormat("[%s]", absl::StrJoin(fields, ", "));
  if (!list.is_array()) {
    return absl::InvalidArgumentError(absl::StrFormat("%s must be an array, %s", key, Got(list)));
  }
  // The bounds are those of PiecesFromWaypoints/PiecesFromPolyline, checked
  // here so that a file is refused before anything is built from it (the
  // server refuses fewer than 2 points too).
  if (list.size() < 2) {
    return absl::InvalidArgumentError(absl::StrFormat("%s has %s; a trajectory needs at least 2",
                                                      key, Plural(list.size(), "point")));
  }
  if (list.size() > kMaxTrajectoryJsonPoints) {
    return absl::InvalidArgumentError(absl::StrFormat("%s has %s; at most %d are accepted", key,
                                                      Plural(list.size(), "point"),
                                                      kMaxTrajectoryJsonPoints));
  }
  std::vector<std::array<double, 4>> points;
  points.reserve(list.size());
  for (size_t i = 0; i < list.size(); ++i) {
    const Json& item = list[i];
    if (!item.is_array()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s[%d] must be an array %s, %s", key, i, shape, Got(item)));
    }
    if (item.size() != fields.size()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s[%d] has %s; expected %d: %s", key, i,
                                                        Plural(item.size(), "value"), fields.size(),
                                                        shape));
    }
    std::array<double, 4>& v = points.emplace_back();
    v.fill(0.0);
    for (size_t k = 0; k < fields.size(); ++k) {
      // JSON has no NaN or infinity, and nlohmann refuses a number beyond the
      // range of a double as a parse error, so every number here is finite.
      if (!item[k].is_number()) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s[%d].%s must be a number, %s", key, i, fields[k], Got(item[k])));
      }
      v[k] = item[k].get<double>();
    }
  }
  return points;
}

// Every error is InvalidArgument, "CONTEXT: what is wrong".
absl::StatusOr<TrajectoryJson> ParseJson(std::string_view json, const std::string& context) {
  auto invalid = [&context](const absl::Status& status) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: %s", context, status.message()));
  };
  absl::StatusOr<Json> doc = ParseObject(json);
  if (!doc.ok()) return invalid(doc.status());
  absl::StatusOr<bool> is_polyline = IsPolyline(*doc);
  if (!is_polyline.ok()) return invalid(is_polyline.status());
  const char* key = *is_polyline ? "polyline" : "waypoints";
  const std::span<const char* const> fields = *is_polyline
                                                  ? std::span<const char* const>(kPolylineFields)
                                                  : std::span<const char* const>(kWaypointFields);
  absl::StatusOr<std::vector<std::array<double, 4>>> points = ReadPoints(doc->at(key), key, fields);
  if (!points.ok()) return invalid(points.status());
  return TrajectoryJson{.is_polyline = *is_polyline, .points = *std::move(points)};
}

// Why a file could not be opened or read ("No such file or directory"), as
// far as errno tells.
std::string ErrnoText() { return errno != 0 ? std::strerror(errno) : "unknown error"; }

// The whole file, refusing one larger than kMaxTrajectoryFileBytes without
// reading past the bound.
absl::StatusOr<std::string> ReadBounded(const std::string& path) {
  const std::string too_large = absl::StrFormat("trajectory file '%s' is larger than %d bytes",
                                                path, kMaxTrajectoryFileBytes);
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(
        absl::StrFormat("cannot open trajectory file '%s': %s", path, ErrnoText()));
  }
  std::string text;
  // A regular file's size is known up front: refuse it unread, or read it
  // without regrowing the string. A pipe or a device has no size; the loop
  // below stops it at the bound.
  std::error_code ec;
  if (const uintmax_t size = std::filesystem::file_size(path, ec); !ec) {
    if (size > kMaxTrajectoryFileBytes) return absl::InvalidArgumentError(too_large);
    text.reserve(size);
  }
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > kMaxTrajectoryFileBytes) return absl::InvalidArgumentError(too_large);
  }
  // A directory opens but cannot be read (EISDIR).
  if (in.bad()) {
    return absl::NotFoundError(
        absl::StrFormat("cannot read trajectory file '%s': %s", path, ErrnoText()));
  }
  return text;
}

}  // namespace

absl::StatusOr<TrajectoryJson> ParseTrajectoryJson(std::string_view json) {
  return ParseJson(json, "trajectory JSON");
}

absl::StatusOr<TrajectoryJson> ReadTrajectoryFile(const std::string& path) {
  absl::StatusOr<std::string> text = ReadBounded(path);
  if (!text.ok()) return text.status();
  return ParseJson(*text, absl::StrFormat("trajectory file '%s'", path));
}

}  // namespace riskplan::formats
