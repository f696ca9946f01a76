#include "client/client.h"

#include <cassert>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "client/channel_target.h"
#include "grpcpp/support/client_interceptor.h"

namespace riskplan::client {

namespace {

// Adds the bearer token to every call's metadata. An interceptor rather than
// call credentials: gRPC sends call credentials over TLS only, and a token
// must also reach a plaintext loopback port.
class TokenInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit TokenInterceptor(const std::string* header) : header_(header) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->emplace("authorization", *header_);
    }
    methods->Proceed();
  }

 private:
  const std::string* const header_;  // the factory's, which the channel keeps
};

class TokenInterceptorFactory final
    : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit TokenInterceptorFactory(std::string token) : header_("Bearer " + token) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(
      grpc::experimental::ClientRpcInfo* /*info*/) override {
    return new TokenInterceptor(&header_);
  }

 private:
  const std::string header_;
};

absl::StatusOr<std::string> ReadFile(const char* flag, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) {
    return absl::NotFoundError(
        absl::StrFormat("--%s=%s: cannot read it: %s", flag, path, std::strerror(errno)));
  }
  return text.str();
}

// Reads a server stream to its end, handing every message to `on_update`
// until it says stop, then cancels the call. The stream is still read to its
// end after a cancel, because Finish may only be called once every message
// has been read; the messages already on their way are dropped, so the
// callback hears nothing after it said stop.
template <typename Update, typename Callback>
grpc::Status ReadUntilStopped(grpc::ClientContext& context, grpc::ClientReader<Update>& reader,
                              const Callback& on_update) {
  Update update;
  bool cancelled = false;
  while (reader.Read(&update)) {
    if (!cancelled && !on_update(update)) {
      context.TryCancel();
      cancelled = true;
    }
  }
  return reader.Finish();
}

// One unary call of `stub` with `timeout` as its deadline, the shape every
// unary method of RiskplanClient shares. Nothing else happens per call: the
// retries of UNAVAILABLE are the channel's (ChannelServiceConfig), and the
// status goes back as gRPC gave it.
template <typename Stub, typename Request, typename Response>
grpc::Status CallUnary(Stub& stub,
                       grpc::Status (Stub::*method)(grpc::ClientContext*, const Request&,
                                                    Response*),
                       const Request& request, Response* response, absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  return (stub.*method)(&context, request, response);
}

}  // namespace

std::string ChannelServiceConfig(bool replicas) {
  return absl::StrCat(
      "{", replicas ? R"json("healthCheckConfig": {"serviceName": "riskplan.v1.Planner"}, )json" : "",
      R"json("methodConfig": [{
    "name": [
      {"service": "riskplan.v1.Planner", "method": "EvaluateRisk"},
      {"service": "riskplan.v1.Planner", "method": "ListMaps"},
      {"service": "riskplan.v1.Planner", "method": "GetMapLayer"},
      {"service": "riskplan.v1.Planner", "method": "GetRiskLayer"},
      {"service": "riskplan.v1.Planner", "method": "Ping"},
      {"service": "grpc.health.v1.Health", "method": "Check"}
    ],
    "retryPolicy": {
      "maxAttempts": 5,
      "initialBackoff": "0.1s",
      "maxBackoff": "1s",
      "backoffMultiplier": 2,
      "retryableStatusCodes": ["UNAVAILABLE"]
    }
  }]
})json");
}

absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(const std::string& address,
                                                           const ConnectionOptions& options,
                                                           const grpc::ChannelArguments& extra) {
  absl::StatusOr<std::string> target = ChannelTarget(address);
  if (!target.ok()) return target.status();
  grpc::ChannelArguments args = extra;
  // The retry policy is the client's own: a service config published in DNS
  // (TXT records) is not looked up, so it cannot replace it.
  // Replicas: a list, or a URI whose resolver may give several addresses.
  const bool replicas = *target != address || absl::StartsWith(address, "dns:") ||
                        absl::StartsWith(address, "ipv4:") || absl::StartsWith(address, "ipv6:");
  args.SetServiceConfigJSON(ChannelServiceConfig(replicas));
  args.SetInt(GRPC_ARG_SERVICE_CONFIG_DISABLE_RESOLUTION, 1);
  // gRPC's default limit is 4 MiB, which a final PlanUpdate with its tree or
  // an EvaluateRisk response with every sample can exceed; the server sends
  // up to 64 MiB (docs/api.md, "Limits").
  args.SetMaxReceiveMessageSize(kMaxReceiveBytes);
  // Spreads calls over every address a name resolves to (e.g. the pods of a
  // headless Kubernetes Service); the same as pick_first for one address.
  args.SetLoadBalancingPolicyName("round_robin");
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (options.tls()) {
    if (options.tls_cert.empty() != options.tls_key.empty()) {
      return absl::InvalidArgumentError("--tls_cert and --tls_key go together");
    }
    grpc::SslCredentialsOptions ssl;
    if (!options.tls_ca.empty()) {
      absl::StatusOr<std::string> ca = ReadFile("tls_ca", options.tls_ca);
      if (!ca.ok()) return ca.status();
      ssl.pem_root_certs = *std::move(ca);
    }
    if (!options.tls_cert.empty()) {
      absl::StatusOr<std::string> cert = ReadFile("tls_cert", options.tls_cert);
      if (!cert.ok()) return cert.status();
      absl::StatusOr<std::string> key = ReadFile("tls_key", options.tls_key);
      if (!key.ok()) return key.status();
      ssl.pem_cert_chain = *std::move(cert);
      ssl.pem_private_key = *std::move(key);
    }
    if (!options.tls_server_name.empty()) args.SetSslTargetNameOverride(options.tls_server_name);
    credentials = grpc::SslCredentials(ssl);
  }
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  if (!options.token_file.empty()) {
    absl::StatusOr<std::string> token = ReadFile("token_file", options.token_file);
    if (!token.ok()) return token.status();
    const absl::string_view trimmed = absl::StripAsciiWhitespace(*token);
    if (trimmed.empty() || trimmed.find_first_of(" \t\r\n") != absl::string_view::npos) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "--token_file=%s: must hold one token (no spaces)", options.token_file));
    }
    interceptors.push_back(std::make_unique<TokenInterceptorFactory>(std::string(trimmed)));
  }
  return grpc::experimental::CreateCustomChannelWithInterceptors(*target, credentials, args,
                                                                 std::move(interceptors));
}

void SetTimeout(grpc::ClientContext* context, absl::Duration timeout) {
  assert(context != nullptr);
  // No deadline is gRPC's default; an infinite one is left unset rather than
  // converted, since absl::InfiniteFuture() has no chrono time_point.
  if (timeout == absl::InfiniteDuration()) return;
  context->set_deadline(absl::ToChronoTime(absl::Now() + timeout));
}

// Plaintext without a token reads no file, so MakeChannel cannot fail.
RiskplanClient::RiskplanClient(const std::string& address)
    : RiskplanClient(*MakeChannel(address)) {}

RiskplanClient::RiskplanClient(std::shared_ptr<grpc::Channel> channel)
    : channel_(std::move(channel)),
      stub_(v1::Planner::NewStub(channel_)),
      health_(grpc::health::v1::Health::NewStub(channel_)) {}

grpc::Status RiskplanClient::ListMaps(v1::ListMapsResponse* response, absl::Duration timeout) {
  return CallUnary(*stub_, &v1::Planner::Stub::ListMaps, v1::ListMapsRequest(), response, timeout);
}

grpc::Status RiskplanClient::GetMapLayer(const v1::GetMapLayerRequest& request,
                                         v1::GetMapLayerResponse* response,
                                         absl::Duration timeout) {
  return CallUnary(*stub_, &v1::Planner::Stub::GetMapLayer, request, response, timeout);
}

grpc::Status RiskplanClient::GetRiskLayer(const v1::GetRiskLayerRequest& request,
                                          v1::GetRiskLayerResponse* response,
                                          absl::Duration timeout) {
  return CallUnary(*stub_, &v1::Planner::Stub::GetRiskLayer, request, response, timeout);
}

grpc::Status RiskplanClient::EvaluateRisk(const v1::EvaluateRiskRequest& request,
                                          v1::EvaluateRiskResponse* response,
                                          absl::Duration timeout) {
  return CallUnary(*stub_, &v1::Planner::Stub::EvaluateRisk, request, response, timeout);
}

grpc::Status RiskplanClient::Ping(absl::Duration timeout) {
  v1::PingResponse response;
  return CallUnary(*stub_, &v1::Planner::Stub::Ping, v1::PingRequest(), &response, timeout);
}

grpc::Status RiskplanClient::Plan(const v1::PlanRequest& request,
                                  const PlanUpdateCallback& on_update, absl::Duration timeout) {
  grpc::ClientContext context;
  SetTimeout(&context, timeout);
  std::unique_ptr<grpc::ClientReader<v1::PlanUpdate>> reader =
      stub_->PlanTrajectory(&context, request);
  return ReadUntilStopped(context, *reader, on_update);
}

namespace {

// A mission's final message that the server's drain sent without planning
// it: the mission has no result yet.
bool Unplanned(const v1::FleetUpdate& u) {
  return u.error_code() == 0 && u.update().final() && u.update().end_reason() == v1::SHUTDOWN &&
         !u.update().has_trajectory();
}

}  // namespace

namespace {

// What the caller of PlanFleet has seen, by mission index in the request,
// across the calls that re-submit unfinished missions: every mission's
// updates pass on with one stream of sequence numbers, each mission gets one
// final, and a re-submitted mission's improvements pass on only when they
// beat what the caller already has.
class FleetProgress {
 public:
  FleetProgress(int missions, const FleetUpdateCallback& on_update)
      : on_update_(on_update),
        ended_(missions, false),
        mission_sequence_(missions, 0),
        best_risk_(missions, std::numeric_limits<double>::infinity()),
        held_(missions),
        sent_(missions) {
    std::iota(sent_.begin(), sent_.end(), 0);
  }

  // The missions of the current call, by their index in the request.
  const std::vector<int>& sent() const { return sent_; }
  bool stopped() const { return stopped_; }

  // One message of call `attempt`; false once the caller stops the stream.
  bool Accept(const v1::FleetUpdate& in, int attempt, int max_resubmits) {
    const int k = in.mission_index();
    // Not a mission of this call: a server's error, passed on as it came.
    if (k < 0 || k >= static_cast<int>(sent_.size())) {
      if (!on_update_(in)) stopped_ = true;
      return !stopped_;
    }
    const int i = sent_[k];
    if (ended_[i]) return true;  // a second final: not passed on
    v1::FleetUpdate u = in;
    u.set_mission_index(i);
    // Held back only while a re-submission may follow; otherwise it is
    // the mission's final, passed on in its place in the stream.
    if (Unplanned(u) && attempt < max_resubmits) {
      held_[i] = std::move(u);
      return true;
    }
    if (u.error_code() == 0 && !u.update().final() && u.update().has_trajectory()) {
      // An improvement: a re-submitted mission starts over, and its first
      // trajectories may be worse than what the caller already has.
      const double risk = u.update().trajectory().risk();
      if (attempt > 0 && !(risk < best_risk_[i])) return true;
      best_risk_[i] = std::min(best_risk_[i], risk);
    }
    return PassOn(std::move(u), attempt);
  }

  // Of `unfinished`, those whose drain-ended final is held back.
  int Held(const std::vector<int>& unfinished) const {
    int held = 0;
    for (int i : unfinished) held += held_[i].has_value() ? 1 : 0;
    return held;
  }

  // The missions of the current call without a final yet.
  std::vector<int> Unfinished() const {
    std::vector<int> unfinished;
    for (int i : sent_) {
      if (!ended_[i]) unfinished.push_back(i);
    }
    return unfinished;
  }

  // Each of `unfinished`'s held Unplanned finals, passed on: a mission the
  // drain of an earlier replica ended unplanned still gets that final. False
  // when the caller stops the stream.
  bool PassHeld(const std::vector<int>& unfinished, int attempt) {
    for (int i : unfinished) {
      if (held_[i].has_value() && !PassOn(*std::move(held_[i]), attempt)) return false;
    }
    return true;
  }

  // The next call sends `unfinished` only.
  void Resubmit(std::vector<int> unfinished) { sent_ = std::move(unfinished); }

 private:
  bool PassOn(v1::FleetUpdate u, int attempt) {
    const int i = u.mission_index();
    const bool final = u.error_code() != 0 || u.update().final();
    if (final) {
      ended_[i] = true;
      ++missions_ended_;
    }
    u.set_sequence(++sequence_);
    u.set_missions_ended(missions_ended_);
    if (u.has_update()) {
      if (attempt > 0) u.mutable_update()->set_sequence(mission_sequence_[i] + 1);
      mission_sequence_[i] = u.update().sequence();
    }
    if (!on_update_(u)) stopped_ = true;
    return !stopped_;
  }

  const FleetUpdateCallback& on_update_;
  std::vector<bool> ended_;
  std::vector<uint64_t> mission_sequence_;
  std::vector<double> best_risk_;
  // The latest Unplanned final of each mission, passed on if the mission
  // gets no other.
  std::vector<std::optional<v1::FleetUpdate>> held_;
  std::vector<int> sent_;
  uint64_t sequence_ = 0;
  int missions_ended_ = 0;
  bool stopped_ = false;
};

}  // namespace

grpc::Status RiskplanClient::PlanFleet(const v1::FleetRequest& request,
                                       const FleetUpdateCallback& on_update,
                                       absl::Duration timeout,
                                       const FleetResubmitOptions& resubmit) {
  const absl::Time deadline =
      timeout == absl::InfiniteDuration() ? absl::InfiniteFuture() : absl::Now() + timeout;
  FleetProgress progress(request.missions_size(), on_update);
  v1::FleetRequest call_request = request;
  for (int attempt = 0;; ++attempt) {
    grpc::ClientContext context;
    if (deadline != absl::InfiniteFuture()) context.set_deadline(absl::ToChronoTime(deadline));
    std::unique_ptr<grpc::ClientReader<v1::FleetUpdate>> reader =
        stub_->PlanFleet(&context, call_request);
    const grpc::Status status = ReadUntilStopped(context, *reader, [&](const v1::FleetUpdate& in) {
      return progress.Accept(in, attempt, resubmit.max_resubmits);
    });
    if (progress.stopped()) return status;
    std::vector<int> unfinished = progress.Unfinished();
    const std::string replica = context.peer();
    if (resubmit.on_call_end) {
      const int sent = static_cast<int>(progress.sent().size());
      resubmit.on_call_end(FleetCallEnd{.attempt = attempt,
                                        .replica = replica,
                                        .status = status,
                                        .sent = sent,
                                        .ended = sent - static_cast<int>(unfinished.size())});
    }
    const absl::Duration wait = resubmit.backoff * (1 << std::min(attempt, 16));
    const bool resubmit_now =
        !unfinished.empty() && attempt < resubmit.max_resubmits &&
        (status.ok() || status.error_code() == grpc::StatusCode::UNAVAILABLE) &&
        absl::Now() + wait < deadline;
    if (!resubmit_now) {
      // Also after a failed re-submission.
      if (!progress.PassHeld(unfinished, attempt)) {
        return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled by the update callback");
      }
      return status;
    }
    if (resubmit.on_resubmit) {
      resubmit.on_resubmit(FleetResubmission{.attempt = attempt + 1,
                                             .broken = status,
                                             .unfinished = static_cast<int>(unfinished.size()),
                                             .replica = replica,
                                             .drained = progress.Held(unfinished),
                                             .missions = unfinished});
    }
    absl::SleepFor(wait);
    call_request.clear_missions();
    for (int i : unfinished) *call_request.add_missions() = request.missions(i);
    progress.Resubmit(std::move(unfinished));
  }
}

grpc::Status RiskplanClient::CheckHealth(
    const std::string& service, grpc::health::v1::HealthCheckResponse::ServingStatus* status,
    absl::Duration timeout) {
  assert(status != nullptr);
  grpc::health::v1::HealthCheckRequest request;
  request.set_service(service);
  grpc::health::v1::HealthCheckResponse response;
  grpc::Status result =
      CallUnary(*health_, &grpc::health::v1::Health::Stub::Check, request, &response, timeout);
  if (result.ok()) *status = response.status();
  return result;
}

std::string ExplainStatus(const grpc::Status& status, const ConnectionOptions& options) {
  const std::string& m = status.error_message();
  const auto has = [&m](absl::string_view text) { return absl::StrContains(m, text); };
  std::string hint;
  switch (status.error_code()) {
    case grpc::StatusCode::UNAUTHENTICATED:
      hint = options.token_file.empty()
                 ? "the server requires a bearer token: give --token_file"
                 : "the server refused the token of --token_file (unknown to it, or revoked)";
      break;
    case grpc::StatusCode::PERMISSION_DENIED:
      hint = "the server knows the token, but its role may not call this method "
             "(docs/security.md, \"Roles\")";
      break;
    case grpc::StatusCode::UNAVAILABLE:
      // gRPC passes on OpenSSL's reason when this side refused; when the
      // server refused, it sends no alert and the client sees only a closed
      // connection.
      if (has("CERTIFICATE_VERIFY_FAILED") || has("certificate verify failed")) {
        hint = "this client refused the server's certificate: it is not signed by --tls_ca (or "
               "by the system's roots without --tls_ca), or it has expired";
      } else if (has("Peer name") || has("peer name") || has("not in peer certificate") ||
                 has("hostname")) {
        hint = "this client refused the server's certificate: it is not for the name asked "
               "(the address's host, or --tls_server_name)";
      } else if (has("WRONG_VERSION_NUMBER") || has("wrong version number") ||
                 (options.tls() && has("Ssl handshake failed") && has("SSL_ERROR_SSL"))) {
        hint = "the TLS handshake failed on this side: is the server speaking plaintext (no "
               "--tls_cert there)?";
      } else if (options.tls() && (has("Handshake") || has("handshake") ||
                                   has("Socket closed") || has("Connection reset") ||
                                   has("failed to connect") || has("Failed to connect") ||
                                   has("End of TCP stream"))) {
        hint = options.tls_cert.empty()
                   ? "the connection closed during the TLS handshake: the server may require a "
                     "client certificate (mutual TLS: give --tls_cert and --tls_key), or not "
                     "speak TLS; the server's log (event tls_handshake_failed) says why"
                   : "the connection closed during the TLS handshake: the server refused this "
                     "client's certificate (signed by a CA it does not trust, revoked, or "
                     "expired), or does not speak TLS; the server's log (event "
                     "tls_handshake_failed) says why";
      } else if (!options.tls() && (has("Socket closed") || has("Connection reset") ||
                                    has("failed to connect") || has("Failed to connect") ||
                                    has("End of TCP stream"))) {
        hint = "the connection closed at once: if the server speaks TLS, give --tls_ca (and "
               "--tls_cert/--tls_key for mutual TLS)";
      }
      break;
    default:
      break;
  }
  return hint.empty() ? m : absl::StrCat(m, " (", hint, ")");
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
