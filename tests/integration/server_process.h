// ServerProcess: the real riskplan-server binary, started for a test on
// 127.0.0.1 port 0. Start() returns once the server has printed its readiness
// line (the port is read from it); no fixed ports, no sleeps.
//
// With RISKPLAN_TEST_SECURITY=tls in the environment, every server Start()
// runs serves mutual TLS and requires a token (certificates made once per
// test process by tests/integration/test_pki.sh, the token of role
// operator), and Channel() and CliServerFlags() connect with them: the
// integration suite runs unchanged with security on
// (docs/security.md, "The integration suite with TLS and tokens").
#ifndef RISKPLAN_TESTS_INTEGRATION_SERVER_PROCESS_H_
#define RISKPLAN_TESTS_INTEGRATION_SERVER_PROCESS_H_

#include <sys/types.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/client.h"
#include "tests/child_process.h"

namespace riskplan::testing {

class ServerProcess {
 public:
  // Starts RISKPLAN_BIN_DIR/riskplan-server --listen=127.0.0.1:0 with
  // `flags` (by default a 2 km demo-city, which loads in a fraction of a
  // second). Fails if the readiness line does not come within `timeout`.
  // With `max_open_files` > 0 the server runs with that RLIMIT_NOFILE.
  static absl::StatusOr<std::unique_ptr<ServerProcess>> Start(
      std::vector<std::string> flags = {}, absl::Duration timeout = absl::Seconds(60),
      int max_open_files = 0);
  // Starts RISKPLAN_BIN_DIR/riskplan-fpga-shim --listen=127.0.0.1:0 with
  // `flags` (e.g. --device=model), up to its readiness line.
  static absl::StatusOr<std::unique_ptr<ServerProcess>> StartShim(
      std::vector<std::string> flags, absl::Duration timeout = absl::Seconds(60));

  // Starts RISKPLAN_BIN_DIR/riskplan-web --listen=127.0.0.1:0
  // --server=`server_address` with `flags`, up to its readiness line (with
  // RISKPLAN_TEST_SECURITY=tls, also the client's TLS and token flags).
  static absl::StatusOr<std::unique_ptr<ServerProcess>> StartWeb(
      const std::string& server_address, std::vector<std::string> flags = {},
      absl::Duration timeout = absl::Seconds(60));

  // Kills the server (SIGKILL) if it still runs.
  ~ServerProcess();

  const std::string& address() const { return address_; }
  // How a client reaches this server: plaintext, or (RISKPLAN_TEST_SECURITY
  // =tls) mutual TLS with the operator's token.
  const client::ConnectionOptions& connection() const { return connection_; }
  // A channel to it with connection() (client::MakeChannel).
  std::shared_ptr<grpc::Channel> Channel() const;
  // "--server=ADDRESS" and, with security on, the riskplan CLI's TLS and
  // token flags.
  std::string CliServerFlags() const;
  pid_t pid() const { return pid_; }

  void Signal(int signal_number);
  // Waits for the process to exit; its exit code, or nullopt on timeout (or
  // when it died of a signal).
  std::optional<int> Wait(absl::Duration timeout);
  // Everything the server wrote to stderr so far (its JSON log lines).
  std::string Stderr() const;

 private:
  ServerProcess() = default;
  // Spawns `args` (args[0] the program) and reads its stdout up to the line
  // starting with `ready_prefix`, whose rest is the address.
  static absl::StatusOr<std::unique_ptr<ServerProcess>> Spawn(std::vector<std::string> args,
                                                              const std::string& ready_prefix,
                                                              absl::Duration timeout,
                                                              int max_open_files = 0);

  pid_t pid_ = -1;
  int pidfd_ = -1;
  bool reaped_ = false;
  std::string address_;
  client::ConnectionOptions connection_;
  std::string stderr_path_;
};

// GET http://ADDRESS/PATH (HTTP/1.0); the response body, or an error (also
// when the server does not answer within 30 s).
absl::StatusOr<std::string> HttpGet(const std::string& address, const std::string& path);

// The metrics address a server started with --metrics_listen logged (its
// "metrics_listening" event, whatever the order of the line's keys), or "".
std::string MetricsAddress(const std::string& log);

// The value of the Prometheus sample `series` (name and labels exactly as
// exposed, e.g. `riskplan_accel_worker_state{state="up",worker="fpga:..."}`)
// in an exposition text, or nullopt when it is absent.
std::optional<double> MetricValue(const std::string& text, const std::string& series);

// The demo-city of 2 km that ServerProcess serves by default, and poses on it
// that are admissible under the default model parameters.
inline constexpr double kSmallCitySizeM = 2000.0;
inline constexpr char kSmallCityStart[] = "300,375,240,0.785";
inline constexpr char kSmallCityGoal[] = "1700,1625,250,0.785";

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_INTEGRATION_SERVER_PROCESS_H_
