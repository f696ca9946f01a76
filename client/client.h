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

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"

namespace riskplan::client {

// Largest message the client accepts (a final PlanUpdate with its tree, or an
// EvaluateRisk response with every sample).
inline constexpr int kMaxReceiveBytes = 64 << 20;

// Called for every PlanUpdate in order. Return false to cancel the call (the
// plan then ends with status CANCELLED).
using PlanUpdateCallback = std::function<bool(const v1::PlanUpdate&)>;

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
// round-robin over every address the target resolves to, the credentials
// and token of `options`, and `extra` channel arguments on top. Errors name
// the flag and file that could not be read (nothing connects yet: a server
// that is down or refuses the handshake shows up as UNAVAILABLE on the first
// call; ExplainStatus says why).
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
