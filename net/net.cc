#include "net/net.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <openssl/err.h>
#include <openssl/ssl.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "net/tls_files.h"

namespace riskplan::net {
namespace {

absl::Status Errno(absl::string_view what) {
  const int e = errno;
  return absl::UnavailableError(absl::StrCat(what, ": ", std::strerror(e)));
}

bool SetNonBlocking(int fd) {
  const int flags = fcntl(fd, F_GETFL, 0);
  return flags >= 0 && fcntl(fd, F_SETFL, flags | O_NONBLOCK) == 0;
}

// Waits until fd is ready for `events` or the deadline passes.
absl::Status WaitFor(int fd, short events, absl::Time deadline, absl::string_view what) {
  while (true) {
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) {
      return absl::DeadlineExceededError(absl::StrCat(what, ": deadline exceeded"));
    }
    pollfd p{fd, events, 0};
    const int64_t ms =
        std::max<int64_t>(1, absl::ToInt64Milliseconds(left + absl::Microseconds(999)));
    const int n = poll(&p, 1, static_cast<int>(std::min<int64_t>(ms, 1 << 30)));
    if (n < 0) {
      if (errno == EINTR) continue;
      return Errno(what);
    }
    if (n > 0) {
      if (p.revents & (POLLERR | POLLNVAL))
        return absl::UnavailableError(absl::StrCat(what, ": socket error"));
      return absl::OkStatus();  // readable/writable, or hung up (the read sees it)
    }
  }
}

struct AddrInfoDeleter {
  void operator()(addrinfo* a) const { freeaddrinfo(a); }
};

absl::StatusOr<std::unique_ptr<addrinfo, AddrInfoDeleter>> Resolve(absl::string_view host_port,
                                                                   bool passive) {
  std::string host;
  int port = 0;
  if (absl::Status s = SplitHostPort(host_port, &host, &port); !s.ok()) return s;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = passive ? AI_PASSIVE : 0;
  addrinfo* result = nullptr;
  const std::string port_text = std::to_string(port);
  const int rc =
      getaddrinfo(host.empty() ? nullptr : host.c_str(), port_text.c_str(), &hints, &result);
  if (rc != 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot resolve '", host_port, "': ", gai_strerror(rc)));
  }
  return std::unique_ptr<addrinfo, AddrInfoDeleter>(result);
}

std::string AddressText(const sockaddr_storage& addr) {
  char host[NI_MAXHOST];
  char port[NI_MAXSERV];
  if (getnameinfo(reinterpret_cast<const sockaddr*>(&addr), sizeof(addr), host, sizeof(host), port,
                  sizeof(port), NI_NUMERICHOST | NI_NUMERICSERV) != 0) {
    return "?";
  }
  if (addr.ss_family == AF_INET6) return absl::StrCat("[", host, "]:", port);
  return absl::StrCat(host, ":", port);
}

}  // namespace

Socket& Socket::operator=(Socket&& other) noexcept {
  if (this != &other) {
    Close();
    ssl_ = std::exchange(other.ssl_, nullptr);
    fd_ = other.Release();
  }
  return *this;
}

void Socket::AttachTls(SSL* ssl) {
  SSL_free(ssl_);
  ssl_ = ssl;
}

int Socket::Release() {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

void Socket::Close() {
  SSL_free(ssl_);
  ssl_ = nullptr;
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
}

void Socket::Shutdown() const {
  if (fd_ >= 0) shutdown(fd_, SHUT_RDWR);
}

bool IsLoopbackHost(const std::string& host) {
  std::string h = host;
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
  if (h == "localhost") return true;
  in_addr v4{};
  if (inet_pton(AF_INET, h.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, h.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
  return false;
}

absl::Status SplitHostPort(absl::string_view host_port, std::string* host, int* port) {
  const size_t colon = host_port.rfind(':');
  if (colon == absl::string_view::npos) {
    return absl::InvalidArgumentError(absl::StrCat("'", host_port, "' is not HOST:PORT"));
  }
  absl::string_view h = host_port.substr(0, colon);
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
  int p = 0;
  if (!absl::SimpleAtoi(host_port.substr(colon + 1), &p) || p < 0 || p > 65535) {
    return absl::InvalidArgumentError(absl::StrCat("'", host_port, "' has no valid port"));
  }
  host->assign(h.data(), h.size());
  *port = p;
  return absl::OkStatus();
}

absl::StatusOr<Socket> ConnectTcp(absl::string_view host_port, absl::Time deadline) {
  auto addrs = Resolve(host_port, false);
  if (!addrs.ok()) return addrs.status();
  absl::Status last = absl::UnavailableError(absl::StrCat("cannot connect to ", host_port));
  for (addrinfo* a = addrs->get(); a != nullptr; a = a->ai_next) {
    Socket s(socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol));
    if (!s.valid() || !SetNonBlocking(s.fd())) {
      last = Errno("socket");
      continue;
    }
    if (connect(s.fd(), a->ai_addr, a->ai_addrlen) != 0) {
      if (errno != EINPROGRESS) {
        last = Errno(absl::StrCat("connect to ", host_port));
        continue;
      }
      if (absl::Status w =
              WaitFor(s.fd(), POLLOUT, deadline, absl::StrCat("connect to ", host_port));
          !w.ok()) {
        last = w;
        continue;
      }
      int err = 0;
      socklen_t len = sizeof(err);
      getsockopt(s.fd(), SOL_SOCKET, SO_ERROR, &err, &len);
      if (err != 0) {
        last = absl::UnavailableError(
            absl::StrCat("connect to ", host_port, ": ", std::strerror(err)));
        continue;
      }
    }
    const int one = 1;
    setsockopt(s.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    return s;
  }
  return last;
}

absl::StatusOr<Socket> ListenTcp(absl::string_view host_port, std::string* bound) {
  auto addrs = Resolve(host_port, true);
  if (!addrs.ok()) return addrs.status();
  absl::Status last = absl::UnavailableError(absl::StrCat("cannot listen on ", host_port));
  for (addrinfo* a = addrs->get(); a != nullptr; a = a->ai_next) {
    Socket s(socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol));
    if (!s.valid()) {
      last = Errno("socket");
      continue;
    }
    const int one = 1;
    setsockopt(s.fd(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    if (bind(s.fd(), a->ai_addr, a->ai_addrlen) != 0 || listen(s.fd(), 64) != 0 ||
        !SetNonBlocking(s.fd())) {
      last = Errno(absl::StrCat("listen on ", host_port));
      continue;
    }
    sockaddr_storage addr{};
    socklen_t len = sizeof(addr);
    getsockname(s.fd(), reinterpret_cast<sockaddr*>(&addr), &len);
    *bound = AddressText(addr);
    return s;
  }
  return last;
}

absl::StatusOr<Socket> Accept(const Socket& listener, absl::Time deadline) {
  while (true) {
    if (absl::Status w = WaitFor(listener.fd(), POLLIN, deadline, "accept"); !w.ok()) return w;
    Socket s(accept4(listener.fd(), nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK));
    if (s.valid()) {
      const int one = 1;
      setsockopt(s.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      return s;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR || errno == ECONNABORTED) {
      continue;
    }
    return Errno("accept");
  }
}

absl::Status WaitReady(const Socket& socket, bool write, absl::Time deadline,
                       absl::string_view what) {
  return WaitFor(socket.fd(), write ? POLLOUT : POLLIN, deadline, what);
}

namespace {

// OpenSSL's reason for a failed read or write, the queue emptied.
absl::Status TlsError(SSL* ssl, int rc, absl::string_view what) {
  const int e = SSL_get_error(ssl, rc);
  if (e == SSL_ERROR_ZERO_RETURN) return absl::UnavailableError("connection closed by peer");
  const std::string reason = OpenSslErrors();
  if (e == SSL_ERROR_SYSCALL && reason.empty()) {
    return errno != 0 ? Errno(what) : absl::UnavailableError("connection closed by peer");
  }
  return absl::UnavailableError(absl::StrCat(what, " (TLS): ", reason));
}

absl::Status TlsSendAll(const Socket& socket, absl::string_view data, absl::Time deadline) {
  size_t sent = 0;
  while (sent < data.size()) {
    ERR_clear_error();
    errno = 0;
    size_t n = 0;
    const int rc = SSL_write_ex(socket.ssl(), data.data() + sent, data.size() - sent, &n);
    if (rc == 1) {
      sent += n;
      continue;
    }
    const int e = SSL_get_error(socket.ssl(), rc);
    if (e == SSL_ERROR_WANT_READ || e == SSL_ERROR_WANT_WRITE) {
      if (absl::Status w = WaitReady(socket, e == SSL_ERROR_WANT_WRITE, deadline, "send"); !w.ok()) {
        return w;
      }
      continue;
    }
    return TlsError(socket.ssl(), rc, "send");
  }
  return absl::OkStatus();
}

absl::Status TlsRecvAll(const Socket& socket, void* data, size_t size, absl::Time deadline) {
  auto* p = static_cast<char*>(data);
  size_t got = 0;
  while (got < size) {
    ERR_clear_error();
    errno = 0;
    size_t n = 0;
    const int rc = SSL_read_ex(socket.ssl(), p + got, size - got, &n);
    if (rc == 1) {
      got += n;
      continue;
    }
    const int e = SSL_get_error(socket.ssl(), rc);
    if (e == SSL_ERROR_WANT_READ || e == SSL_ERROR_WANT_WRITE) {
      if (absl::Status w = WaitReady(socket, e == SSL_ERROR_WANT_WRITE, deadline, "receive");
          !w.ok()) {
        return w;
      }
      continue;
    }
    return TlsError(socket.ssl(), rc, "receive");
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status SendAll(const Socket& socket, absl::string_view data, absl::Time deadline) {
  if (socket.ssl() != nullptr) return TlsSendAll(socket, data, deadline);
  size_t sent = 0;
  while (sent < data.size()) {
    const ssize_t n = send(socket.fd(), data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
    if (n > 0) {
      sent += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
      if (absl::Status w = WaitFor(socket.fd(), POLLOUT, deadline, "send"); !w.ok()) return w;
      continue;
    }
    return Errno("send");
  }
  return absl::OkStatus();
}

absl::Status RecvAll(const Socket& socket, void* data, size_t size, absl::Time deadline) {
  if (socket.ssl() != nullptr) return TlsRecvAll(socket, data, size, deadline);
  auto* p = static_cast<char*>(data);
  size_t got = 0;
  while (got < size) {
    const ssize_t n = recv(socket.fd(), p + got, size - got, 0);
    if (n > 0) {
      got += static_cast<size_t>(n);
      continue;
    }
    if (n == 0) return absl::UnavailableError("connection closed by peer");
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
      if (absl::Status w = WaitFor(socket.fd(), POLLIN, deadline, "receive"); !w.ok()) return w;
      continue;
    }
    return Errno("receive");
  }
  return absl::OkStatus();
}

}  // namespace riskplan::net
