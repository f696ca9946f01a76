// RiskplanClient: a thin synchronous client of riskplan.v1.Planner and of
// the standard health service. Depends on the API (proto/) only, never on
// core/.
//
// Thread-safe: one client (one channel) may serve many threads at once.
#ifndef RISKPLAN_CLIENT_CLIENT_H_
#define RISKPLAN_CLIENT_CLIENT_H_

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"

namespace riskplan::client {

// Largest message the client accepts (a final PlanUpdate with its tree, or an
// EvaluateRisk response with every sample).
inline constexpr int kMaxReceiveBytes = 64 << 20;

// The channel's service config (MakeChannel). Calls that change nothing on
// the server (EvaluateRisk, ListMaps, GetMapLayer, GetRiskLayer, Ping and the
// health check) are retried by gRPC when they fail UNAVAILABLE (a replica
// killed or draining, a connection reset), up to 4 more attempts with
// backoff from 0.1 s to 1 s; with round_robin, a retry goes to the next
// replica. PlanTrajectory and PlanFleet are not retried by gRPC (a stream
// already delivering results cannot start over unseen); PlanFleet
// re-submits its unfinished missions itself.
//
// With `replicas` (a static list, or a dns:, ipv4: or ipv6: URI), gRPC's
// client-side health checking is on as well: round-robin picks only
// replicas whose health service says riskplan.v1.Planner is SERVING, so a
// replica stops getting new calls the moment its drain begins (SIGTERM),
// not when its port closes. For one HOST:PORT it is off, so that a client
// of a draining server hears the server's own refusal ("shutting down").
std::string ChannelServiceConfig(bool replicas);

// Called for every PlanUpdate in order. Return false to cancel the call (the
// plan then ends with status CANCELLED).
using PlanUpdateCallback = std::function<bool(const v1::PlanUpdate&)>;
// Called for every FleetUpdate in order; false cancels the call (every
// mission stops; the call ends with CANCELLED).
using FleetUpdateCallback = std::function<bool(const v1::FleetUpdate&)>;

// A fleet's stream broke (or the server's drain ended missions unplanned)
// and its unfinished missions are sent again (RiskplanClient::PlanFleet).
struct FleetResubmission {
  int attempt = 0;      // 1 for the first re-submission
  grpc::Status broken;  // how the previous call ended
  int unfinished = 0;   // missions sent again
  // The replica the previous call went to (its peer, "ipv4:127.0.0.1:50051";
  // empty if it never connected).
  std::string replica;
  // Of `unfinished`, how many the replica's drain ended unplanned (final
  // SHUTDOWN without a trajectory): the replica was draining; the others
  // were lost with the stream.
  int drained = 0;
  std::vector<int> missions;  // sent again, by index in the request
};

// One call of PlanFleet has ended (the first, or a re-submission).
struct FleetCallEnd {
  int attempt = 0;       // 0 for the first call
  std::string replica;   // its peer, as above
  grpc::Status status;   // how it ended
  int sent = 0;          // missions it carried
  int ended = 0;         // of them, those that got their final in it
};

// How PlanFleet re-submits unfinished missions.
struct FleetResubmitOptions {
  // Calls after the first; 0: one call, its missions as the server ends them.
  int max_resubmits = 3;
  // Wait before the first re-submission, doubled before each further one.
  absl::Duration backoff = absl::Milliseconds(250);
  // Told of every re-submission before it is sent (may be null).
  std::function<void(const FleetResubmission&)> on_resubmit;
  // Told when each call ends, before any re-submission (may be null): which
  // replica a call (a re-submission's too) went to, and what it ended.
  std::function<void(const FleetCallEnd&)> on_call_end;
};

// How a client reaches the server (the `riskplan` flags of the same names,
// and any other program built on this library, e.g. a gateway). Every field
// empty: plaintext without a token.
struct ConnectionOptions {
  // TLS: the CA bundle (PEM) that must have signed the server's certificate;
  // empty with TLS on: the system's roots.
  std::string tls_ca;
  // Mutual TLS: this client's certificate chain and key (PEM), both or none.
  std::string tls_cert;
  std::string tls_key;
  // The name the server's certificate must carry, when it is not the host of
  // the address (an IP address, a port-forward, a load balancer).
  std::string tls_server_name;
  // A file holding one bearer token (surrounding whitespace ignored), sent
  // as `authorization: Bearer TOKEN` with every call, over TLS or plaintext.
  std::string token_file;

  // TLS is on when any of the TLS fields is set.
  bool tls() const {
    return !tls_ca.empty() || !tls_cert.empty() || !tls_key.empty() || !tls_server_name.empty();
  }
};

// The one place a channel to riskplan-server is made (the CLI, the load
// generator, the tests and the web gateway all come here): large messages,
// round-robin over every address the target resolves to (`address` as
// ChannelTarget takes it: one address, a URI such as dns:///name:port, or a
// static comma-separated list), gRPC's retry of UNAVAILABLE for the calls
// that change nothing and health-aware balancing over replicas
// (ChannelServiceConfig), the credentials and token of
// `options`, and `extra` channel arguments on top. Errors name the flag and
// file that could not be read, or the list entry that is wrong (nothing
// connects yet: a server that is down or refuses the handshake shows up as
// UNAVAILABLE on the first call; ExplainStatus says why).
absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(
    const std::string& address, const ConnectionOptions& options = {},
    const grpc::ChannelArguments& extra = {});

// `status`'s message, followed for a failure to connect or a refusal by what
// it most likely means with these options (which side refused, and why, as
// far as gRPC tells: a server that requires TLS or a client certificate, a
// certificate not signed by --tls_ca or not for the name asked, a missing or
// unknown token, a role too low).
std::string ExplainStatus(const grpc::Status& status, const ConnectionOptions& options);

class RiskplanClient {
 public:
  // A client of the server at `address` ("host:port"), plaintext. Connects
  // lazily: errors show up as UNAVAILABLE on the first call.
  explicit RiskplanClient(const std::string& address);
  // A client on an existing channel (tests, custom credentials).
  explicit RiskplanClient(std::shared_ptr<grpc::Channel> channel);

  // Unary calls. `timeout` is the call's deadline (absl::InfiniteDuration():
  // none).
  grpc::Status ListMaps(v1::ListMapsResponse* response, absl::Duration timeout = absl::Seconds(10));
  grpc::Status GetMapLayer(const v1::GetMapLayerRequest& request, v1::GetMapLayerResponse* response,
                           absl::Duration timeout = absl::Seconds(30));
  grpc::Status GetRiskLayer(const v1::GetRiskLayerRequest& request,
                            v1::GetRiskLayerResponse* response,
                            absl::Duration timeout = absl::Seconds(60));
  grpc::Status EvaluateRisk(const v1::EvaluateRiskRequest& request,
                            v1::EvaluateRiskResponse* response,
                            absl::Duration timeout = absl::Seconds(30));
  grpc::Status Ping(absl::Duration timeout = absl::Seconds(10));

  // Runs a plan to its end, passing every update to `on_update`. Returns the
  // call's status: OK after the final message, CANCELLED when `on_update`
  // returned false, DEADLINE_EXCEEDED past `timeout`, or the server's error.
  grpc::Status Plan(const v1::PlanRequest& request, const PlanUpdateCallback& on_update,
                    absl::Duration timeout = absl::InfiniteDuration());

  // Runs a fleet to its end, passing every update to `on_update`: each
  // mission's improvements (with send_improvements) and its one final
  // message or error. The status as Plan's.
  //
  // Every mission gets exactly one final message or error, also when a
  // replica fails: when the stream ends UNAVAILABLE (the server died, or
  // its connection did) or ends with missions the server's drain never
  // planned (final SHUTDOWN without a trajectory: held back, not passed on),
  // the missions without a final are sent again in a new call, which the
  // channel's round-robin gives to a replica that is up, at most
  // `resubmit.max_resubmits` times, within `timeout`. A re-submitted mission
  // starts over with its whole budget; a SHUTDOWN final with a trajectory
  // is a result and is kept. The updates passed on look like one call's:
  // mission_index is the mission's index in `request`, sequence and
  // missions_ended count over every call, a mission's update.sequence goes
  // on from its last one, and a re-submitted mission's improvements are
  // passed on only when they beat its best so far. A held-back SHUTDOWN final
  // is passed on when its mission gets no other (no re-submission follows,
  // or the re-submissions failed); the status is that of the last call. With
  // one HOST:PORT, a re-submission goes to the same address (behind a
  // Kubernetes Service, another pod).
  grpc::Status PlanFleet(const v1::FleetRequest& request, const FleetUpdateCallback& on_update,
                         absl::Duration timeout = absl::InfiniteDuration(),
                         const FleetResubmitOptions& resubmit = {});

  // grpc.health.v1.Health/Check of `service` ("" for the whole server);
  // `*status` is set when the call succeeds. REQUIRES: status != nullptr.
  grpc::Status CheckHealth(const std::string& service,
                           grpc::health::v1::HealthCheckResponse::ServingStatus* status,
                           absl::Duration timeout = absl::Seconds(5));

  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  v1::Planner::Stub& stub() { return *stub_; }

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::Planner::Stub> stub_;
  std::unique_ptr<grpc::health::v1::Health::Stub> health_;
};

// Sets `context`'s deadline to now + `timeout` (nothing for an infinite one).
// REQUIRES: context != nullptr.
void SetTimeout(grpc::ClientContext* context, absl::Duration timeout);

// "OK", "CANCELLED", ... "UNAUTHENTICATED": the canonical name of a gRPC
// status code ("UNKNOWN" for a value outside the canonical set).
std::string StatusCodeName(grpc::StatusCode code);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CLIENT_H_
