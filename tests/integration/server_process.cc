#include "tests/integration/server_process.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"

namespace riskplan::testing {
namespace {

int PollMs(absl::Duration left) {
  return static_cast<int>(std::max<int64_t>(0, absl::ToInt64Milliseconds(left)));
}

// RISKPLAN_TEST_SECURITY=tls: the PKI and token of this test process, made
// on first use (and left in /tmp for the process's servers; they are small).
struct TestSecurity {
  std::vector<std::string> server_flags;
  client::ConnectionOptions connection;
};

const TestSecurity* Security() {
  static const TestSecurity* security = []() -> const TestSecurity* {
    const char* mode = std::getenv("RISKPLAN_TEST_SECURITY");
    if (mode == nullptr || std::string(mode) != "tls") return nullptr;
    char dir_template[] = "/tmp/riskplan-test-security-XXXXXX";
    if (mkdtemp(dir_template) == nullptr) std::abort();
    const std::string dir = dir_template;
    const std::string pki = std::string(RISKPLAN_SOURCE_DIR) + "/tests/integration/test_pki.sh";
    const std::string from =
        absl::FormatTime("%Y%m%d%H%M%SZ", absl::Now() - absl::Hours(1), absl::UTCTimeZone());
    const std::string until =
        absl::FormatTime("%Y%m%d%H%M%SZ", absl::Now() + absl::Hours(48), absl::UTCTimeZone());
    const std::string token = "integration-suite-operator-token";
    for (const std::string& command :
         {absl::StrCat("bash ", pki, " init ", dir),
          absl::StrCat("bash ", pki, " issue ", dir,
                       " server a localhost 'DNS:localhost,IP:127.0.0.1' server ", from, " ",
                       until),
          absl::StrCat("bash ", pki, " issue ", dir, " client a integration-suite '' client ", from,
                       " ", until),
          absl::StrCat("printf %s '", token, "' > ", dir, "/operator.token"),
          absl::StrCat("printf '%s suite operator\n' \"$(printf %s '", token,
                       "' | sha256sum | cut -c1-64)\" > ", dir, "/tokens.txt")}) {
      if (std::system(command.c_str()) != 0) {
        std::fprintf(stderr, "RISKPLAN_TEST_SECURITY=tls: '%s' failed\n", command.c_str());
        std::abort();
      }
    }
    auto* s = new TestSecurity;
    s->server_flags = {"--tls_cert=" + dir + "/server.pem", "--tls_key=" + dir + "/server.key",
                       "--tls_client_ca=" + dir + "/ca-a.pem",
                       "--token_file=" + dir + "/tokens.txt"};
    s->connection.tls_ca = dir + "/ca-a.pem";
    s->connection.tls_cert = dir + "/client.pem";
    s->connection.tls_key = dir + "/client.key";
    s->connection.token_file = dir + "/operator.token";
    return s;
  }();
  return security;
}

}  // namespace

std::shared_ptr<grpc::Channel> ServerProcess::Channel() const {
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel =
      client::MakeChannel(address_, connection_);
  if (!channel.ok()) {
    std::fprintf(stderr, "ServerProcess::Channel: %s\n",
                 std::string(channel.status().message()).c_str());
    std::abort();
  }
  return *channel;
}

std::string ServerProcess::CliServerFlags() const {
  std::string flags = "--server=" + address_;
  if (!connection_.tls_ca.empty()) {
    absl::StrAppend(&flags, " --tls_ca=", connection_.tls_ca, " --tls_cert=", connection_.tls_cert,
                    " --tls_key=", connection_.tls_key, " --token_file=", connection_.token_file);
  }
  return flags;
}

absl::StatusOr<std::unique_ptr<ServerProcess>> ServerProcess::Start(std::vector<std::string> flags,
                                                                    absl::Duration timeout,
                                                                    int max_open_files) {
  std::vector<std::string> args = {std::string(RISKPLAN_BIN_DIR) + "/riskplan-server",
                                   "--listen=127.0.0.1:0"};
  bool has_maps = false;
  for (const std::string& f : flags) has_maps = has_maps || absl::StartsWith(f, "--maps=");
  if (!has_maps) args.push_back(absl::StrCat("--demo_city_size_m=", kSmallCitySizeM));
  const TestSecurity* security = Security();
  if (security != nullptr) {
    args.insert(args.end(), security->server_flags.begin(), security->server_flags.end());
  }
  // The test's own flags last: they win (a test of TLS flags sets its own).
  args.insert(args.end(), flags.begin(), flags.end());
  absl::StatusOr<std::unique_ptr<ServerProcess>> server =
      Spawn(std::move(args), "riskplan-server listening on ", timeout, max_open_files);
  if (server.ok() && security != nullptr) (*server)->connection_ = security->connection;
  return server;
}

absl::StatusOr<std::unique_ptr<ServerProcess>> ServerProcess::StartShim(
    std::vector<std::string> flags, absl::Duration timeout) {
  std::vector<std::string> args = {std::string(RISKPLAN_BIN_DIR) + "/riskplan-fpga-shim",
                                   "--listen=127.0.0.1:0"};
  args.insert(args.end(), flags.begin(), flags.end());
  return Spawn(std::move(args), "riskplan-fpga-shim listening on ", timeout);
}

absl::StatusOr<std::unique_ptr<ServerProcess>> ServerProcess::StartWeb(
    const std::string& server_address, std::vector<std::string> flags, absl::Duration timeout) {
  std::vector<std::string> args = {std::string(RISKPLAN_BIN_DIR) + "/riskplan-web",
                                   "--listen=127.0.0.1:0", "--server=" + server_address};
  // RISKPLAN_TEST_SECURITY=tls: the gateway is a client of a server that
  // wants mutual TLS and a token, like the suite's other clients.
  if (const TestSecurity* security = Security(); security != nullptr) {
    const client::ConnectionOptions& c = security->connection;
    for (std::string flag : {"--tls_ca=" + c.tls_ca, "--tls_cert=" + c.tls_cert,
                             "--tls_key=" + c.tls_key, "--token_file=" + c.token_file}) {
      args.push_back(std::move(flag));
    }
  }
  args.insert(args.end(), flags.begin(), flags.end());
  return Spawn(std::move(args), "riskplan-web listening on ", timeout);
}

absl::StatusOr<std::unique_ptr<ServerProcess>> ServerProcess::Spawn(std::vector<std::string> args,
                                                                    const std::string& ready_prefix,
                                                                    absl::Duration timeout,
                                                                    int max_open_files) {
  std::unique_ptr<ServerProcess> server(new ServerProcess);
  char stderr_template[] = "/tmp/riskplan-server-stderr-XXXXXX";
  const int stderr_fd = mkostemp(stderr_template, O_CLOEXEC);
  if (stderr_fd < 0) return absl::InternalError("mkstemp failed");
  server->stderr_path_ = stderr_template;
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) {
    close(stderr_fd);
    return absl::InternalError("pipe failed");
  }

  absl::StatusOr<pid_t> pid = SpawnProcess(
      args,
      SpawnOptions{.stdout_fd = out[1], .stderr_fd = stderr_fd, .max_open_files = max_open_files});
  close(out[1]);
  close(stderr_fd);
  if (!pid.ok()) {
    close(out[0]);
    return pid.status();
  }
  server->pid_ = *pid;
  server->pidfd_ = static_cast<int>(syscall(SYS_pidfd_open, server->pid_, 0));

  // Read stdout until the readiness line (or EOF: the server failed).
  std::string text;
  const absl::Time deadline = absl::Now() + timeout;
  while (true) {
    const size_t newline = text.find('\n');
    if (newline != std::string::npos) {
      const std::string line = text.substr(0, newline);
      text.erase(0, newline + 1);
      if (absl::StartsWith(line, ready_prefix)) {
        server->address_ = line.substr(ready_prefix.size());
        break;
      }
      continue;
    }
    pollfd p{out[0], POLLIN, 0};
    if (poll(&p, 1, PollMs(deadline - absl::Now())) <= 0) {
      close(out[0]);
      return absl::DeadlineExceededError(
          absl::StrCat(args[0], " did not print its readiness line; stderr:\n", server->Stderr()));
    }
    char buffer[512];
    const ssize_t n = read(out[0], buffer, sizeof(buffer));
    if (n <= 0) {
      close(out[0]);
      return absl::UnavailableError(
          absl::StrCat(args[0], " exited before serving; stderr:\n", server->Stderr()));
    }
    text.append(buffer, static_cast<size_t>(n));
  }
  // The server prints nothing else on stdout; keep the pipe drained anyway
  // by closing our end (a later write would get EPIPE, which it never does).
  close(out[0]);
  return server;
}

ServerProcess::~ServerProcess() {
  if (pid_ > 0 && !reaped_) {
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  if (pidfd_ >= 0) close(pidfd_);
  if (!stderr_path_.empty()) unlink(stderr_path_.c_str());
}

void ServerProcess::Signal(int signal_number) {
  if (pid_ > 0 && !reaped_) kill(pid_, signal_number);
}

std::optional<int> ServerProcess::Wait(absl::Duration timeout) {
  if (reaped_) return std::nullopt;
  if (pidfd_ >= 0) {
    pollfd p{pidfd_, POLLIN, 0};
    if (poll(&p, 1, PollMs(timeout)) <= 0) return std::nullopt;
  }
  int status = 0;
  if (waitpid(pid_, &status, 0) != pid_) return std::nullopt;
  reaped_ = true;
  if (!WIFEXITED(status)) return std::nullopt;
  return WEXITSTATUS(status);
}

std::string ServerProcess::Stderr() const {
  std::ifstream in(stderr_path_);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

absl::StatusOr<std::string> HttpGet(const std::string& address, const std::string& path) {
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos) return absl::InvalidArgumentError("address needs a port");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(std::stoi(address.substr(colon + 1))));
  if (inet_pton(AF_INET, address.substr(0, colon).c_str(), &addr.sin_addr) != 1) {
    return absl::InvalidArgumentError("address needs an IPv4 host");
  }
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return absl::InternalError("socket failed");
  // A server that stops answering fails the test instead of hanging it.
  const timeval io_timeout{30, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &io_timeout, sizeof(io_timeout));
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &io_timeout, sizeof(io_timeout));
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    close(fd);
    return absl::UnavailableError("cannot connect to " + address);
  }
  const std::string request = "GET " + path + " HTTP/1.0\r\nHost: " + address + "\r\n\r\n";
  if (write(fd, request.data(), request.size()) != static_cast<ssize_t>(request.size())) {
    close(fd);
    return absl::UnavailableError("cannot send the request");
  }
  std::string response;
  char buffer[4096];
  ssize_t n = 0;
  while ((n = read(fd, buffer, sizeof(buffer))) > 0)
    response.append(buffer, static_cast<size_t>(n));
  const bool timed_out = n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
  close(fd);
  if (timed_out) return absl::DeadlineExceededError("no answer from " + address + " in 30 s");
  const size_t body = response.find("\r\n\r\n");
  if (body == std::string::npos) return absl::DataLossError("no HTTP body");
  return response.substr(body + 4);
}

std::string MetricsAddress(const std::string& log) {
  std::smatch match;
  if (!std::regex_search(
          log, match,
          std::regex("\\{[^\n]*\"detail\":\"([0-9.:]+)\"[^\n]*\"event\":\"metrics_listening\"|"
                     "\"event\":\"metrics_listening\",\"detail\":\"([0-9.:]+)\""))) {
    return "";
  }
  return match[1].matched ? match[1] : match[2];
}

namespace {

// "name{a=\"1\",b=\"2\"}" -> name and its labels in sorted order, so that two
// spellings of a series compare equal whatever their label order.
std::string CanonicalSeries(const std::string& series) {
  const size_t brace = series.find('{');
  if (brace == std::string::npos) return series;
  std::vector<std::string> labels;
  const std::string body = series.substr(brace + 1, series.rfind('}') - brace - 1);
  size_t start = 0;
  bool quoted = false;
  for (size_t i = 0; i <= body.size(); ++i) {
    if (i < body.size() && body[i] == '"' && (i == 0 || body[i - 1] != '\\')) quoted = !quoted;
    if (i == body.size() || (body[i] == ',' && !quoted)) {
      if (i > start) labels.push_back(body.substr(start, i - start));
      start = i + 1;
    }
  }
  std::sort(labels.begin(), labels.end());
  return absl::StrCat(series.substr(0, brace), "{", absl::StrJoin(labels, ","), "}");
}

}  // namespace

std::optional<double> MetricValue(const std::string& text, const std::string& series) {
  const std::string want = CanonicalSeries(series);
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.rfind(' ');
    if (space == std::string::npos) continue;
    if (CanonicalSeries(line.substr(0, space)) == want) return std::stod(line.substr(space + 1));
  }
  return std::nullopt;
}

}  // namespace riskplan::testing
