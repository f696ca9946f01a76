// What the gateway's route files (gateway.cc, gateway_missions.cc,
// gateway_flights.cc) share: how an answer or a refusal is sent, and the
// lookups they all need. Not for other users.
#ifndef RISKPLAN_WEB_GATEWAY_INTERNAL_H_
#define RISKPLAN_WEB_GATEWAY_INTERNAL_H_

#include <string>

#include "absl/status/status.h"
#include "google/protobuf/message.h"
#include "grpcpp/grpcpp.h"
#include "nlohmann/json.hpp"
#include "riskplan/v1/planner.pb.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace riskplan::web::gateway_internal {

// What the page sees of a failed request: the code, the message exactly as
// its author wrote it, and who wrote it ("server" or "gateway").
void SendError(httplib::Response& res, int http_status, const std::string& code,
               const std::string& message, const char* source);
// The server's status, with the HTTP status of its code.
void SendServerError(httplib::Response& res, const grpc::Status& status);
// The gateway's own refusal, with the HTTP status of its code.
void SendGatewayError(httplib::Response& res, const absl::Status& status);
void SendJson(httplib::Response& res, std::string json, int http_status = 200);
// The same, gzipped (`gzip`, or made here when empty) when the browser
// takes gzip and the answer is worth it.
void SendJsonTo(const httplib::Request& req, httplib::Response& res, std::string json,
                std::string gzip = "");
// The map `name` of `maps`, or null.
const v1::MapInfo* FindMap(const v1::ListMapsResponse& maps, const std::string& name);
// `root[key]` (an object) as the API message `*message`; absent: left as
// is. InvalidArgument naming the key.
absl::Status JsonMessageField(const nlohmann::json& root, const char* key,
                              google::protobuf::Message* message);

}  // namespace riskplan::web::gateway_internal

#endif  // RISKPLAN_WEB_GATEWAY_INTERNAL_H_
