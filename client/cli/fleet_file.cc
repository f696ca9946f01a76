#include "client/cli/fleet_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/cli/option_requests.h"
#include "nlohmann/json.hpp"

namespace riskplan::client {
namespace {

using Json = nlohmann::json;

// Sets one field of `o` from the mission's value at `key`; errors name
// `where` (the JSON path).
absl::Status SetOption(const std::string& key, const Json& value, const std::string& where,
                       CliOptions* o) {
  const auto text = [&](std::string* out) -> absl::Status {
    if (value.is_string()) {
      *out = value.get<std::string>();
      return absl::OkStatus();
    }
    // A pose or a point list as numbers: [x, y, z, theta].
    if (value.is_array() && (key == "start" || key == "goal")) {
      std::vector<std::string> parts;
      for (const Json& v : value) {
        if (!v.is_number()) break;
        parts.push_back(absl::StrFormat("%.17g", v.get<double>()));
      }
      if (parts.size() == value.size()) {
        *out = absl::StrJoin(parts, ",");
        return absl::OkStatus();
      }
    }
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: must be a string%s", where,
        key == "start" || key == "goal" ? " ('x,y,z,theta') or an array of 4 numbers" : ""));
  };
  const auto integer = [&](int64_t* out) -> absl::Status {
    if (!value.is_number_integer()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: must be an integer", where));
    }
    *out = value.get<int64_t>();
    return absl::OkStatus();
  };
  if (key == "start") return text(&o->start);
  if (key == "goal") return text(&o->goal);
  if (key == "map") return text(&o->map);
  if (key == "algorithm") return text(&o->algorithm);
  if (key == "params") return text(&o->params);
  if (key == "wind") return text(&o->wind);
  if (key == "planner_params") return text(&o->planner_params);
  if (key == "obstacles") return text(&o->obstacles);
  if (key == "budget_ms") return integer(&o->budget_ms);
  if (key == "iterations") return integer(&o->iterations);
  if (key == "min_update_interval_ms") return integer(&o->min_update_interval_ms);
  if (key == "seed") {
    if (!value.is_number_unsigned()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: must be an integer >= 0", where));
    }
    o->seed = value.get<uint64_t>();
    return absl::OkStatus();
  }
  const auto number = [&](double* out) -> absl::Status {
    if (!value.is_number()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: must be a number", where));
    }
    *out = value.get<double>();
    return absl::OkStatus();
  };
  if (key == "max_flight_time_s") return number(&o->max_flight_time_s);
  if (key == "max_length_m") return number(&o->max_length_m);
  if (key == "max_risk") return number(&o->max_risk);
  if (key == "max_risk_per_flight_hour") return number(&o->max_risk_per_flight_hour);
  if (key == "objective") return text(&o->objective);
  if (key == "pareto") {
    if (!value.is_boolean()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: must be true or false", where));
    }
    o->pareto = value.get<bool>();
    return absl::OkStatus();
  }
  if (key == "display_step_m") {
    if (!value.is_number()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: must be a number", where));
    }
    o->display_step_m = value.get<double>();
    return absl::OkStatus();
  }
  if (key == "tree") {
    if (!value.is_boolean()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: must be true or false", where));
    }
    o->tree = value.get<bool>();
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s: unknown key; a mission has id, priority, start, goal, map, algorithm, budget_ms, "
      "iterations, seed, params, wind, planner_params, obstacles, min_update_interval_ms, "
      "display_step_m, tree, max_flight_time_s, max_length_m, max_risk, "
      "max_risk_per_flight_hour, objective, pareto",
      where));
}

absl::StatusOr<v1::FleetMission> MissionFromJson(const Json& m, const std::string& where,
                                                 const CliOptions& base) {
  if (!m.is_object()) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: must be an object", where));
  }
  v1::FleetMission mission;
  CliOptions o = base;
  for (const auto& [key, value] : m.items()) {
    const std::string at = absl::StrFormat("%s.%s", where, key);
    if (key == "id") {
      if (!value.is_string()) {
        return absl::InvalidArgumentError(absl::StrFormat("%s: must be a string", at));
      }
      mission.set_id(value.get<std::string>());
    } else if (key == "priority") {
      if (!value.is_number_integer() || value.get<int64_t>() < 0 || value.get<int64_t>() > 1000) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s: must be an integer in [0, 1000]", at));
      }
      mission.set_priority(value.get<int>());
    } else if (absl::Status s = SetOption(key, value, at, &o); !s.ok()) {
      return s;
    }
  }
  if (mission.id().empty()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.id: required (a non-empty string)", where));
  }
  if (o.start.empty() || o.goal.empty()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: no %s: give the mission one, or --%s for every mission", where,
                        o.start.empty() ? "start" : "goal", o.start.empty() ? "start" : "goal"));
  }
  absl::StatusOr<v1::PlanRequest> request = PlanRequestFromOptions(o);
  if (!request.ok()) {
    // Its messages name the flags ("--algorithm=X: unknown"); here the
    // mission's key of the same name.
    std::string message(request.status().message());
    if (absl::StartsWith(message, "--")) {
      return absl::InvalidArgumentError(absl::StrFormat("%s.%s", where, message.substr(2)));
    }
    return absl::InvalidArgumentError(absl::StrFormat("%s: %s", where, message));
  }
  *mission.mutable_request() = *std::move(request);
  return mission;
}

}  // namespace

absl::StatusOr<v1::FleetRequest> ParseMissionsJson(std::string_view json,
                                                   const std::string& context,
                                                   const CliOptions& base) {
  const auto invalid = [&context](const std::string& detail) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: %s", context, detail));
  };
  Json doc;
  try {
    doc = Json::parse(json.begin(), json.end());
  } catch (const Json::exception& e) {
    // Its message carries the line and column of a syntax error.
    return invalid(absl::StrFormat("not JSON: %s", e.what()));
  }
  if (!doc.is_object()) return invalid("must be a JSON object with \"missions\"");
  v1::FleetRequest request;
  for (const auto& [key, value] : doc.items()) {
    if (key == "tenant") {
      if (!value.is_string()) return invalid("tenant: must be a string");
      request.set_tenant(value.get<std::string>());
    } else if (key == "send_improvements") {
      if (!value.is_boolean()) return invalid("send_improvements: must be true or false");
      request.set_send_improvements(value.get<bool>());
    } else if (key != "missions") {
      return invalid(absl::StrFormat(
          "%s: unknown key; the file has missions, tenant and send_improvements", key));
    }
  }
  auto missions = doc.find("missions");
  if (missions == doc.end() || !missions->is_array() || missions->empty()) {
    return invalid("missions: required, an array of at least one mission");
  }
  for (size_t i = 0; i < missions->size(); ++i) {
    absl::StatusOr<v1::FleetMission> m =
        MissionFromJson((*missions)[i], absl::StrFormat("missions[%d]", i), base);
    if (!m.ok()) return invalid(std::string(m.status().message()));
    *request.add_missions() = *std::move(m);
  }
  return request;
}

absl::StatusOr<v1::FleetRequest> ReadMissionsFile(const std::string& path, const CliOptions& base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(
        absl::StrFormat("cannot open missions file '%s': %s", path, std::strerror(errno)));
  }
  std::string text;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > kMaxMissionsFileBytes) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "missions file '%s' is larger than %d bytes", path, kMaxMissionsFileBytes));
    }
  }
  return ParseMissionsJson(text, absl::StrFormat("missions file '%s'", path), base);
}

}  // namespace riskplan::client
