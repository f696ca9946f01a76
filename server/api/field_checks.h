// The smallest checks of request fields, shared by request_validation.h,
// wgs84_fields.h and risk_layer_request.h: a number that must be finite, and
// an error prefixed by the field it concerns. Depends on nothing of the
// server, so that every validating file can use it without including the
// others.
#ifndef RISKPLAN_SERVER_API_FIELD_CHECKS_H_
#define RISKPLAN_SERVER_API_FIELD_CHECKS_H_

#include <string_view>

#include "absl/status/status.h"

namespace riskplan::server {

// INVALID_ARGUMENT "FIELD has value V; it must be finite" unless `value` is
// finite.
absl::Status CheckFinite(double value, std::string_view field);

// `status` with its message prefixed by the request field it concerns,
// "FIELD: MESSAGE" (OK stays OK).
absl::Status InField(std::string_view field, const absl::Status& status);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_FIELD_CHECKS_H_
