// Blocking TCP with deadlines: the shim link on both ends (accel/, the
// riskplan-fpga-shim daemon), and the server's host:port checks. Every
// call that waits takes an absolute deadline and fails with
// DeadlineExceeded when it passes; a closed or reset connection is
// Unavailable. Sockets are non-blocking underneath and waited on with
// poll(), so a deadline holds even when the peer never answers.
#ifndef RISKPLAN_NET_NET_H_
#define RISKPLAN_NET_NET_H_

#include <cstddef>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

typedef struct ssl_st SSL;

namespace riskplan::net {

// Owns a file descriptor, and the TLS session on it once one is attached
// (net/tls_context.h); closes both on destruction. Move-only.
class Socket {
 public:
  Socket() = default;
  explicit Socket(int fd) : fd_(fd) {}
  Socket(Socket&& other) noexcept : fd_(other.Release()), ssl_(other.ssl_) { other.ssl_ = nullptr; }
  Socket& operator=(Socket&& other) noexcept;
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;
  ~Socket() { Close(); }

  int fd() const { return fd_; }
  // The TLS session, or null: plaintext.
  SSL* ssl() const { return ssl_; }
  // Takes `ssl`: from now on SendAll and RecvAll go through it.
  void AttachTls(SSL* ssl);
  bool valid() const { return fd_ >= 0; }
  int Release();
  void Close();
  // Wakes any thread blocked on this socket (shutdown both ways); the
  // descriptor stays open until Close(). Thread-safe with respect to I/O.
  void Shutdown() const;

 private:
  int fd_ = -1;
  SSL* ssl_ = nullptr;
};

// Splits "host:port" ("[v6]:port" for IPv6). InvalidArgument when malformed.
absl::Status SplitHostPort(absl::string_view host_port, std::string* host, int* port);

// True for 127.0.0.0/8, ::1 ("[::1]" too) and "localhost": the addresses
// where plaintext is allowed without being asked for.
bool IsLoopbackHost(const std::string& host);

// Connects to "host:port" (resolved with getaddrinfo, which does not honour
// the deadline).
absl::StatusOr<Socket> ConnectTcp(absl::string_view host_port, absl::Time deadline);

// Listens on "host:port" (port 0 picks one); *bound gets the real
// "host:port".
absl::StatusOr<Socket> ListenTcp(absl::string_view host_port, std::string* bound);

// Waits for a connection until `deadline`.
absl::StatusOr<Socket> Accept(const Socket& listener, absl::Time deadline);

// Waits until `socket` is writable (`write`) or readable, or `deadline`.
absl::Status WaitReady(const Socket& socket, bool write, absl::Time deadline,
                       absl::string_view what);

// Both go through the TLS session when the socket has one.
absl::Status SendAll(const Socket& socket, absl::string_view data, absl::Time deadline);
absl::Status RecvAll(const Socket& socket, void* data, size_t size, absl::Time deadline);

}  // namespace riskplan::net

#endif  // RISKPLAN_NET_NET_H_
