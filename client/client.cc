#include "client/client.h"

#include <cassert>
#include <iterator>
#include <utility>

namespace riskplan::client {

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const grpc::ChannelArguments& extra) {
  grpc::ChannelArguments args = extra;
  // gRPC's default limit is 4 MiB, which a final PlanUpdate with its tree or
  // an EvaluateRisk response with every sample can exceed; the server sends
  // up to 64 MiB (docs/api.md, "Limits").
  args.SetMaxReceiveMessageSize(kMaxReceiveBytes);
  // Spreads calls over every address a name resolves to (e.g. the pods of a
  // headless Kubernetes Service); the same as pick_first for one address.
  args.SetLoadBalancingPolicyName("round_robin");
  // Plaintext, as the server listens: it has no TLS of its own.
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

void SetTimeout(grpc::ClientContext* context, absl::Duration timeout) {
  assert(context != nullptr);
  // No deadline is gRPC's default; an infinite one is left unset rather than
  // converted, since absl::InfiniteFuture() has no chrono time_point.
  if (timeout == absl::InfiniteDuration()) return;
  context->set_deadline(absl::ToChronoTime(absl::Now() + timeout));
}

RiskplanClient::RiskplanClient(const std::string& address) : RiskplanClient(MakeChannel(address)) {}

RiskplanClient::RiskplanClient(std::shared_ptr<grpc::Channel> channel)
    : channel_(std::move(channel)),
      stub_(v1::Planner::NewStub(channel_)),
      health_(grpc::health::v1::Health::NewStub(channel_)) {}

grpc::Status RiskplanClient::ListMaps(v1::ListMapsResponse* response, absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  return stub_->ListMaps(&context, v1::ListMapsRequest(), response);
}

grpc::Status RiskplanClient::GetMapLayer(const v1::GetMapLayerRequest& request,
                                         v1::GetMapLayerResponse* response,
                                         absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  return stub_->GetMapLayer(&context, request, response);
}

grpc::Status RiskplanClient::GetRiskLayer(const v1::GetRiskLayerRequest& request,
                                          v1::GetRiskLayerResponse* response,
                                          absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  return stub_->GetRiskLayer(&context, request, response);
}

grpc::Status RiskplanClient::EvaluateRisk(const v1::EvaluateRiskRequest& request,
                                          v1::EvaluateRiskResponse* response,
                                          absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  return stub_->EvaluateRisk(&context, request, response);
}

grpc::Status RiskplanClient::Ping(absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  v1::PingResponse response;
  return stub_->Ping(&context, v1::PingRequest(), &response);
}

grpc::Status RiskplanClient::Plan(const v1::PlanRequest& request,
                                  const PlanUpdateCallback& on_update, absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  std::unique_ptr<grpc::ClientReader<v1::PlanUpdate>> reader =
      stub_->PlanTrajectory(&context, request);
  v1::PlanUpdate update;
  bool cancelled = false;
  // After a cancel the stream is still read to its end, because Finish may
  // only be called once every message has been read; the updates already on
  // their way are dropped, so the callback hears nothing after it said stop.
  while (reader->Read(&update)) {
    if (!cancelled && !on_update(update)) {
      context.TryCancel();
      cancelled = true;
    }
  }
  return reader->Finish();
}

grpc::Status RiskplanClient::CheckHealth(
    const std::string& service, grpc::health::v1::HealthCheckResponse::ServingStatus* status,
    absl::Duration timeout) {
  assert(status != nullptr);
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  grpc::health::v1::HealthCheckRequest request;
  request.set_service(service);
  grpc::health::v1::HealthCheckResponse response;
  grpc::Status result = health_->Check(&context, request, &response);
  if (result.ok()) *status = response.status();
  return result;
}

std::string StatusCodeName(grpc::StatusCode code) {
  // Indexed by the code's value: gRPC fixes the canonical codes as 0 to 16,
  // and the names are those of docs/api.md and of the load reports.
  static const char* const kNames[] = {"OK",
                                       "CANCELLED",
                                       "UNKNOWN",
                                       "INVALID_ARGUMENT",
                                       "DEADLINE_EXCEEDED",
                                       "NOT_FOUND",
                                       "ALREADY_EXISTS",
                                       "PERMISSION_DENIED",
                                       "RESOURCE_EXHAUSTED",
                                       "FAILED_PRECONDITION",
                                       "ABORTED",
                                       "OUT_OF_RANGE",
                                       "UNIMPLEMENTED",
                                       "INTERNAL",
                                       "UNAVAILABLE",
                                       "DATA_LOSS",
                                       "UNAUTHENTICATED"};
  static_assert(std::size(kNames) == grpc::StatusCode::UNAUTHENTICATED + 1);
  // A server or a proxy may send any integer as a code.
  const int i = static_cast<int>(code);
  return i >= 0 && i < static_cast<int>(std::size(kNames)) ? kNames[i] : "UNKNOWN";
}

}  // namespace riskplan::client
