#include "server/api/field_checks.h"

#include <cmath>
#include <string>

#include "absl/strings/str_format.h"

namespace riskplan::server {

absl::Status CheckFinite(double value, std::string_view field) {
  if (std::isfinite(value)) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrFormat("%s has value %g; it must be finite", std::string(field), value));
}

absl::Status InField(std::string_view field, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(),
                      absl::StrFormat("%s: %s", std::string(field), status.message()));
}

}  // namespace riskplan::server
