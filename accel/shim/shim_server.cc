#include "accel/shim/shim_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "accel/frame_io.h"

namespace riskplan::accel {
namespace {

// "127.0.0.1:51234" or "[::1]:51234", for the log of a refused handshake.
std::string PeerName(const net::Socket& socket) {
  sockaddr_storage peer{};
  socklen_t length = sizeof(peer);
  if (getpeername(socket.fd(), reinterpret_cast<sockaddr*>(&peer), &length) != 0) return "?";
  char host[INET6_ADDRSTRLEN] = "";
  if (peer.ss_family == AF_INET6) {
    const auto* a = reinterpret_cast<const sockaddr_in6*>(&peer);
    inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof(host));
    return absl::StrCat("[", host, "]:", ntohs(a->sin6_port));
  }
  const auto* a = reinterpret_cast<const sockaddr_in*>(&peer);
  inet_ntop(AF_INET, &a->sin_addr, host, sizeof(host));
  return absl::StrCat(host, ":", ntohs(a->sin_port));
}

}  // namespace

ShimServer::ShimServer(std::unique_ptr<EwmmDevice> device, const ShimServerOptions& options)
    : device_(std::move(device)), options_(options) {
  store_ = std::make_unique<BlobStore>(device_->info().format,
                                       static_cast<int>(device_->info().max_kernel_side),
                                       options.limits.store_bytes);
  context_.device = device_.get();
  context_.store = store_.get();
  context_.limits = options.limits;
}

ShimServer::~ShimServer() { Stop(); }

absl::StatusOr<std::string> ShimServer::Start(const std::string& listen) {
  std::string bound;
  absl::StatusOr<net::Socket> listener = net::ListenTcp(listen, &bound);
  if (!listener.ok()) return listener.status();
  listener_ = *std::move(listener);
  accept_thread_ = std::thread([this] { AcceptLoop(); });
  return bound;
}

void ShimServer::AcceptLoop() {
  while (true) {
    {
      absl::MutexLock lock(&mu_);
      if (stopping_) return;
      // Reap finished connections.
      for (auto it = connections_.begin(); it != connections_.end();) {
        if (it->finished) {
          it->thread.join();
          it = connections_.erase(it);
        } else {
          ++it;
        }
      }
    }
    // Short waits so that Stop() is noticed promptly.
    absl::StatusOr<net::Socket> socket =
        net::Accept(listener_, absl::Now() + absl::Milliseconds(100));
    if (!socket.ok()) continue;
    absl::MutexLock lock(&mu_);
    if (stopping_) return;
    // Over the limit the socket is closed unanswered (it goes out of scope).
    if (static_cast<int>(connections_.size()) >= options_.max_connections) continue;
    ++accepted_;
    connections_.emplace_back();
    Connection* c = &connections_.back();
    c->socket = *std::move(socket);
    c->thread = std::thread([this, c] { Serve(c); });
  }
}

void ShimServer::Serve(Connection* connection) {
  if (options_.tls != nullptr) {
    absl::Status handshake = options_.tls->Accept(
        &connection->socket, absl::Now() + options_.handshake_timeout);
    if (options_.on_tls_event) {
      for (const std::string& line : options_.tls->TakeReloadLog()) options_.on_tls_event(line);
      if (!handshake.ok()) {
        options_.on_tls_event(absl::StrCat("refused ", PeerName(connection->socket), ": ",
                                           handshake.message()));
      }
    }
    if (!handshake.ok()) {
      connection->socket.Shutdown();
      absl::MutexLock lock(&mu_);
      connection->finished = true;
      return;
    }
  }
  ShimSession session(&context_);
  std::string payload;
  while (true) {
    FrameHeader header;
    absl::Status s = ReadFrame(connection->socket, options_.limits.max_payload_bytes,
                               absl::Now() + options_.idle_timeout, &header, &payload);
    if (!s.ok()) {
      // A corrupt header or an oversized payload is answered with ERROR
      // MALFORMED (request id 0: the header cannot be trusted), then the
      // connection is closed (docs/shim-protocol.md, "Frames").
      if (s.code() == absl::StatusCode::kDataLoss ||
          s.code() == absl::StatusCode::kResourceExhausted) {
        net::SendAll(connection->socket,
                     ShimSession::ErrorFrame(0, ShimErrorCode::kMalformed, s.message()),
                     absl::Now() + absl::Seconds(1))
            .IgnoreError();
      }
      break;
    }
    bool close = false;
    const std::string reply = session.Handle(header, payload, &close);
    if (!net::SendAll(connection->socket, reply, absl::Now() + options_.idle_timeout).ok() ||
        close) {
      break;
    }
  }
  connection->socket.Shutdown();
  absl::MutexLock lock(&mu_);
  connection->finished = true;
}

void ShimServer::Stop() {
  {
    absl::MutexLock lock(&mu_);
    if (stopping_) return;
    stopping_ = true;
    for (Connection& c : connections_) c.socket.Shutdown();
  }
  if (accept_thread_.joinable()) accept_thread_.join();
  std::list<Connection> connections;
  {
    absl::MutexLock lock(&mu_);
    connections.swap(connections_);
  }
  for (Connection& c : connections) {
    if (c.thread.joinable()) c.thread.join();
  }
  listener_.Close();
}

uint64_t ShimServer::connections_accepted() const {
  absl::MutexLock lock(&mu_);
  return accepted_;
}

}  // namespace riskplan::accel
