#include "core/flight/trajectory_io.h"

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <span>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
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

namespace {

// The trajectory JSON rule of docs/api.md ("Trajectory files"). The client
// implements it again in client/trajectory_text.cc; keep the two in step
// (tests/data/trajectory_json_cases.json tests both).

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

absl::StatusOr<TrajectoryInput> ParseJson(std::string_view json, const std::string& context) {
  auto invalid = [&context](const std::string& detail) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: %s", context, detail));
  };
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
    return invalid("not valid JSON: " + what);
  }
  if (!doc.is_object()) {
    return invalid(absl::StrFormat("the top level must be an object, %s", Got(doc)));
  }
  if (!repeated.empty()) {
    return invalid(absl::StrFormat("key %s appears twice", Shown(Json(repeated))));
  }
  // Unknown keys are refused rather than ignored: a key such as "units" or
  // "frame" that this reader does not know could change what the numbers
  // mean, and a misspelt key would otherwise go unnoticed.
  for (const auto& [key, value] : doc.items()) {
    if (key != "waypoints" && key != "polyline") {
      return invalid(absl::StrFormat(
          "unknown key %s; the only keys are \"waypoints\" and \"polyline\"", Shown(Json(key))));
    }
  }
  const bool has_waypoints = doc.contains("waypoints");
  const bool has_polyline = doc.contains("polyline");
  if (has_waypoints == has_polyline) {
    return invalid(absl::StrFormat("needs exactly one of \"waypoints\" and \"polyline\", got %s",
                                   has_waypoints ? "both" : "neither"));
  }
  const char* key = has_waypoints ? "waypoints" : "polyline";
  const std::span<const char* const> fields = has_waypoints
                                                  ? std::span<const char* const>(kWaypointFields)
                                                  : std::span<const char* const>(kPolylineFields);
  const std::string shape = absl::StrFormat("[%s]", absl::StrJoin(fields, ", "));
  const Json& list = doc.at(key);
  if (!list.is_array()) return invalid(absl::StrFormat("%s must be an array, %s", key, Got(list)));
  // The bounds are those of PiecesFromWaypoints/PiecesFromPolyline, checked
  // here so that a file is refused before anything is built from it.
  if (list.size() < 2) {
    return invalid(absl::StrFormat("%s has %s; a trajectory needs at least 2", key,
                                   Plural(list.size(), "point")));
  }
  if (list.size() > kMaxTrajectoryJsonPoints) {
    return invalid(absl::StrFormat("%s has %s; at most %d are accepted", key,
                                   Plural(list.size(), "point"), kMaxTrajectoryJsonPoints));
  }
  TrajectoryInput out;
  if (has_waypoints) {
    out.waypoints.reserve(list.size());
  } else {
    out.polyline.reserve(list.size());
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const Json& item = list[i];
    if (!item.is_array()) {
      return invalid(absl::StrFormat("%s[%d] must be an array %s, %s", key, i, shape, Got(item)));
    }
    if (item.size() != fields.size()) {
      return invalid(absl::StrFormat("%s[%d] has %s; expected %d: %s", key, i,
                                     Plural(item.size(), "value"), fields.size(), shape));
    }
    double v[4] = {0, 0, 0, 0};
    for (size_t k = 0; k < fields.size(); ++k) {
      // JSON has no NaN or infinity, and nlohmann refuses a number beyond the
      // range of a double as a parse error, so every number here is finite.
      if (!item[k].is_number()) {
        return invalid(
            absl::StrFormat("%s[%d].%s must be a number, %s", key, i, fields[k], Got(item[k])));
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

absl::StatusOr<TrajectoryInput> ParseTrajectoryJson(std::string_view json) {
  return ParseJson(json, "trajectory JSON");
}

absl::StatusOr<TrajectoryInput> ReadTrajectoryFile(const std::string& path) {
  absl::StatusOr<std::string> text = ReadBounded(path);
  if (!text.ok()) return text.status();
  return ParseJson(*text, absl::StrFormat("trajectory file '%s'", path));
}

}  // namespace riskplan
