// The one place where riskplan's absl::Status becomes a grpc::Status.
//
// core/ and accel/ report errors as absl::Status; the RPC edge converts them
// here and nowhere else, so that a status code means the same thing whichever
// RPC returns it (docs/api.md lists them).
#ifndef RISKPLAN_SERVER_STATUS_UTIL_H_
#define RISKPLAN_SERVER_STATUS_UTIL_H_

#include <string_view>

#include "absl/status/status.h"
#include "grpcpp/support/status.h"

namespace riskplan::server {

// Same code (the numeric values of absl::StatusCode and grpc::StatusCode are
// those of google.rpc.Code), same message. Unknown codes become UNKNOWN.
grpc::Status ToGrpcStatus(const absl::Status& status);

// The canonical upper-case name of a gRPC status code, e.g. "RESOURCE_EXHAUSTED"
// (for logs and metric labels).
std::string_view GrpcCodeName(grpc::StatusCode code);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_STATUS_UTIL_H_
