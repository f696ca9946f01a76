// The one place where riskplan's absl::Status becomes a grpc::Status.
//
// core/ and accel/ report errors as absl::Status; the RPC edge converts them
// here and nowhere else, so that a status code means the same thing whichever
// RPC returns it (docs/api.md lists them).
#ifndef RISKPLAN_SERVER_API_STATUS_UTIL_H_
#define RISKPLAN_SERVER_API_STATUS_UTIL_H_

#include <exception>
#include <string_view>

#include "absl/status/status.h"
#include "grpcpp/support/status.h"

namespace riskplan::server {

// Same code (the numeric values of absl::StatusCode and grpc::StatusCode are
// those of google.rpc.Code), same message. Unknown codes become UNKNOWN.
grpc::Status ToGrpcStatus(const absl::Status& status);

// The status of a request whose work threw `exception` (`what` says which
// work, e.g. "EvaluateRisk"): RESOURCE_EXHAUSTED for std::bad_alloc (the
// server ran out of memory; another replica, or the same one later, may
// not), INTERNAL naming the exception otherwise. No exception leaves a
// request's thread: the pools and handlers catch them and end the call with
// this status.
absl::Status StatusFromException(const std::exception& exception, std::string_view what);

// The canonical upper-case name of a gRPC status code, e.g. "RESOURCE_EXHAUSTED"
// (for logs and metric labels).
std::string_view GrpcCodeName(grpc::StatusCode code);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_STATUS_UTIL_H_
