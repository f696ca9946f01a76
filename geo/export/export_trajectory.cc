#include "geo/export/export_trajectory.h"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "absl/strings/str_format.h"

namespace riskplan::geo {

absl::Status CheckExportTrajectory(const ExportTrajectory& t) {
  if (t.samples.size() < 2) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "export: the trajectory has %d samples; at least 2 are needed", t.samples.size()));
  }
  for (size_t k = 0; k < t.samples.size(); ++k) {
    const ExportSample& s = t.samples[k];
    if (!(s.lat_deg >= -90.0 && s.lat_deg <= 90.0 && s.lon_deg >= -180.0 && s.lon_deg <= 180.0) ||
        !std::isfinite(s.alt_m) || !std::isfinite(s.heading_deg) ||
        !std::isfinite(s.arc_length_m)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "export: sample %d at (%.9g, %.9g) deg, altitude %.9g m, heading %.9g deg, arc length "
          "%.9g m: latitudes must be in [-90, 90], longitudes in [-180, 180], the rest finite",
          k, s.lat_deg, s.lon_deg, s.alt_m, s.heading_deg, s.arc_length_m));
    }
  }
  for (auto [name, value] : {std::pair{"risk", t.risk},
                             {"length_m", t.length_m},
                             {"flight_time_s", t.flight_time_s},
                             {"risk_per_flight_hour", t.risk_per_flight_hour},
                             {"airspeed_mps", t.airspeed_mps},
                             {"wind_speed_mps", t.wind_speed_mps},
                             {"wind_from_true_deg", t.wind_from_true_deg},
                             {"spacing_m", t.spacing_m}}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("export: %s is %g; it must be finite", name, value));
    }
  }
  return absl::OkStatus();
}

// A temporary file renamed over the name, so that a reader sees the old file
// or the new one, never a part; the pid keeps two processes writing the same
// name apart.
absl::Status WriteTextFileAtomically(const std::string& text, const std::string& path) {
  const std::string tmp = absl::StrFormat("%s.tmp-%d", path, getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) {
      const int error = errno;
      std::remove(tmp.c_str());
      return absl::UnavailableError(
          absl::StrFormat("cannot write '%s': %s", path, std::strerror(error)));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(tmp.c_str());
    return absl::UnavailableError(
        absl::StrFormat("cannot write '%s': %s", path, std::strerror(error)));
  }
  return absl::OkStatus();
}

}  // namespace riskplan::geo
