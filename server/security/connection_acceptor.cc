#include "server/security/connection_acceptor.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "net/net.h"
#include "server/observability/grpc_log.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {
namespace {

constexpr int kFirstPauseMs = 100;
constexpr int kLongestPauseMs = 1000;
constexpr absl::Duration kLogEvery = absl::Seconds(10);

// Failures that say nothing about the listener, only about one connection
// that went away before it was accepted (accept(2), "Error handling"): the
// next accept is tried at once.
bool IsConnectionError(int error) {
  switch (error) {
    case ECONNABORTED:
    case EPROTO:
    case ENETDOWN:
    case ENOPROTOOPT:
    case EHOSTDOWN:
    case ENONET:
    case EHOSTUNREACH:
    case EOPNOTSUPP:
    case ENETUNREACH:
    case EPERM:  // a firewall rule refused it
      return true;
    default:
      return false;
  }
}

// "EMFILE: Too many open files".
std::string ErrorText(int error) {
  const char* name = error == EMFILE    ? "EMFILE: "
                     : error == ENFILE  ? "ENFILE: "
                     : error == ENOBUFS ? "ENOBUFS: "
                     : error == ENOMEM  ? "ENOMEM: "
                                        : "";
  return absl::StrCat(name, std::strerror(error));
}

// "ipv4:127.0.0.1:51234" or "ipv6:[::1]:51234", as gRPC names peers.
std::string PeerText(const sockaddr_storage& peer) {
  char host[INET6_ADDRSTRLEN] = "";
  if (peer.ss_family == AF_INET) {
    const auto* a = reinterpret_cast<const sockaddr_in*>(&peer);
    inet_ntop(AF_INET, &a->sin_addr, host, sizeof(host));
    return absl::StrFormat("ipv4:%s:%d", host, ntohs(a->sin_port));
  }
  if (peer.ss_family == AF_INET6) {
    const auto* a = reinterpret_cast<const sockaddr_in6*>(&peer);
    inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof(host));
    return absl::StrFormat("ipv6:[%s]:%d", host, ntohs(a->sin6_port));
  }
  return "unknown";
}

}  // namespace

absl::StatusOr<std::unique_ptr<ConnectionAcceptor>> ConnectionAcceptor::Listen(
    const std::string& host_port) {
  std::string host;
  int port = 0;
  if (absl::Status s = net::SplitHostPort(host_port, &host, &port); !s.ok()) return s;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* addresses = nullptr;
  const std::string port_text = std::to_string(port);
  if (const int rc =
          getaddrinfo(host.empty() ? nullptr : host.c_str(), port_text.c_str(), &hints, &addresses);
      rc != 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot resolve '", host_port, "': ", gai_strerror(rc)));
  }
  std::unique_ptr<ConnectionAcceptor> acceptor(new ConnectionAcceptor);
  std::string last_error = "no address";
  for (addrinfo* a = addresses; a != nullptr && acceptor->listen_fd_ < 0; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) {
      last_error = std::strerror(errno);
      continue;
    }
    const int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    // Accepted sockets inherit it, as from gRPC's own listener.
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    if (bind(fd, a->ai_addr, a->ai_addrlen) != 0 || listen(fd, SOMAXCONN) != 0) {
      last_error = std::strerror(errno);
      close(fd);
      continue;
    }
    sockaddr_storage bound{};
    socklen_t length = sizeof(bound);
    getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &length);
    acceptor->port_ =
        ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                          : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
    acceptor->listen_fd_ = fd;
  }
  freeaddrinfo(addresses);
  if (acceptor->listen_fd_ < 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", host_port, ": ", last_error));
  }
  int wake[2];
  if (pipe2(wake, O_CLOEXEC | O_NONBLOCK) != 0) {
    return absl::UnavailableError(absl::StrCat("cannot make a pipe: ", std::strerror(errno)));
  }
  acceptor->wake_read_fd_ = wake[0];
  acceptor->wake_write_fd_ = wake[1];
  return acceptor;
}

ConnectionAcceptor::~ConnectionAcceptor() {
  Stop();
  for (int fd : {listen_fd_, wake_read_fd_, wake_write_fd_}) {
    if (fd >= 0) close(fd);
  }
}

void ConnectionAcceptor::Start(
    std::unique_ptr<grpc::experimental::ExternalConnectionAcceptor> grpc_acceptor,
    std::function<void()> on_error) {
  grpc_acceptor_ = std::move(grpc_acceptor);
  on_error_ = std::move(on_error);
  thread_ = std::thread([this] { Run(); });
}

void ConnectionAcceptor::Stop() {
  if (stopping_.exchange(true)) {
    if (thread_.joinable()) thread_.join();
    return;
  }
  const char byte = 0;
  (void)!write(wake_write_fd_, &byte, 1);
  if (thread_.joinable()) thread_.join();
  if (listen_fd_ >= 0) {
    close(listen_fd_);
    listen_fd_ = -1;
  }
}

bool ConnectionAcceptor::WaitReadable(int pause_ms) {
  pollfd fds[2] = {{wake_read_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}};
  // While accept fails for want of resources, only the wake-up is waited
  // for: the listener stays readable, and the pause is the point.
  const nfds_t count = pause_ms < 0 ? 2 : 1;
  while (!stopping_.load()) {
    const int ready = poll(fds, count, pause_ms);
    if (ready < 0 && errno == EINTR) continue;
    return !stopping_.load();
  }
  return false;
}

void ConnectionAcceptor::Run() {
  int pause_ms = -1;  // >= 0 while accept keeps failing
  int64_t failures = 0;
  absl::Time first_failure, last_logged;
  while (WaitReadable(pause_ms)) {
    sockaddr_storage peer{};
    socklen_t peer_length = sizeof(peer);
    const int fd = accept4(listen_fd_, reinterpret_cast<sockaddr*>(&peer), &peer_length,
                           SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (fd >= 0) {
      // For the attribution of TLS handshake failures (server/observability/grpc_log.h).
      NoteAcceptedPeer(PeerText(peer));
      if (failures > 0) {
        LogEvent("accept_resumed",
                 absl::StrFormat("failures=%d seconds=%.3f", failures,
                                 absl::ToDoubleSeconds(absl::Now() - first_failure)));
        failures = 0;
      }
      pause_ms = -1;
      grpc::experimental::ExternalConnectionAcceptor::NewConnectionParameters connection;
      connection.listener_fd = listen_fd_;
      connection.fd = fd;  // gRPC owns it from here
      grpc_acceptor_->HandleNewConnection(&connection);
      continue;
    }
    const int error = errno;
    if (error == EAGAIN || error == EWOULDBLOCK || error == EINTR) {
      pause_ms = -1;  // nothing (left) to accept: wait for the next connection
      continue;
    }
    if (IsConnectionError(error)) continue;
    // Out of descriptors or memory (or a listener gone bad, which no retry
    // mends but which is logged all the same): pause, then try again.
    const absl::Time now = absl::Now();
    if (failures == 0) first_failure = now;
    ++failures;
    if (on_error_) on_error_();
    if (failures == 1 || now - last_logged >= kLogEvery) {
      LogEvent("accept_failed",
               absl::StrFormat("failures=%d port=%d error=%s; new connections wait in the listen "
                               "backlog, open ones are served",
                               failures, port_, ErrorText(error)));
      last_logged = now;
    }
    pause_ms = pause_ms < 0 ? kFirstPauseMs : std::min(2 * pause_ms, kLongestPauseMs);
  }
}

}  // namespace riskplan::server
