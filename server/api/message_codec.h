// The service's own parsing of requests and serialisation of responses.
//
// Every method of riskplan.v1.Planner is registered raw (grpc::ByteBuffer in
// and out, PlannerService in planner_service.h), because gRPC's generated
// handlers answer a request whose bytes do not parse with UNIMPLEMENTED and an
// empty message: in gRPC 1.51 (grpcpp/impl/codegen/server_callback_handlers.h)
// the callback handlers replace any deserialisation failure by
// Status(UNIMPLEMENTED, "") before the service sees the call, whatever the
// deserialiser returned. Parsed here instead, such a request gets
// INVALID_ARGUMENT saying which message it is not.
#ifndef RISKPLAN_SERVER_API_MESSAGE_CODEC_H_
#define RISKPLAN_SERVER_API_MESSAGE_CODEC_H_

#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/impl/codegen/proto_utils.h"

namespace riskplan::server {

// Parses `raw` as a `Request`. INVALID_ARGUMENT when it carries no message
// or bytes that are not one, e.g. "request: the 7 bytes received are not a
// riskplan.v1.EvaluateRiskRequest (protobuf wire format)".
template <typename Request>
absl::Status ParseRequest(const grpc::ByteBuffer& raw, Request* request) {
  if (!raw.Valid()) {
    return absl::InvalidArgumentError(absl::StrFormat("request: the call carries no %s message",
                                                      Request::descriptor()->full_name()));
  }
  // Deserialize consumes its buffer; the copy shares the slices.
  grpc::ByteBuffer copy(raw);
  if (grpc::SerializationTraits<Request>::Deserialize(&copy, request).ok()) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(
      absl::StrFormat("request: the %d bytes received are not a %s (protobuf wire format)",
                      raw.Length(), Request::descriptor()->full_name()));
}

// Serialises `message` into `raw`, replacing what it held (a stream reuses
// one buffer for its writes). INTERNAL if protobuf refuses (a message over
// 2 GiB, which the request limits keep far away).
template <typename Message>
absl::Status SerializeMessage(const Message& message, grpc::ByteBuffer* raw) {
  raw->Clear();  // gRPC's writer requires an empty buffer
  bool own_buffer = false;
  grpc::Status s = grpc::SerializationTraits<Message>::Serialize(message, raw, &own_buffer);
  if (s.ok()) return absl::OkStatus();
  return absl::InternalError(absl::StrFormat(
      "cannot serialise the %s: %s", Message::descriptor()->full_name(), s.error_message()));
}

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_MESSAGE_CODEC_H_
