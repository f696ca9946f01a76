// ConnectionAcceptor: the server's listening socket and its accept loop,
// handing every connection to gRPC through an ExternalConnectionAcceptor.
//
// Why not gRPC's own listener: in gRPC 1.51 an accept4() that fails with
// anything but EAGAIN or EINTR (EMFILE when the process is out of file
// descriptors, ENFILE, ENOBUFS, ENOMEM) closes the listener for good
// (src/core/lib/iomgr/tcp_server_posix.cc logs "Failed accept4" and
// deactivates the port): the server keeps serving the connections it has but
// never accepts another one, even once descriptors are free again. Here such
// a failure is logged and counted, and accept is tried again after a pause
// (100 ms, doubling up to 1 s) while new connections wait in the listen
// backlog; they are served as soon as a descriptor is free.
//
// Log events (server/observability/rpc_log.h): "accept_failed" at the first failure of a
// run of failures and at most every 10 s while it lasts (the reason, e.g.
// "Too many open files", and the failures so far), and "accept_resumed"
// with their count once a connection is accepted again.
//
// Thread-safe: the loop runs on its own thread; Stop() may be called from any
// thread.
#ifndef RISKPLAN_SERVER_SECURITY_CONNECTION_ACCEPTOR_H_
#define RISKPLAN_SERVER_SECURITY_CONNECTION_ACCEPTOR_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "grpcpp/server_builder.h"

namespace riskplan::server {

class ConnectionAcceptor {
 public:
  // Binds "HOST:PORT" ("[V6]:PORT" for IPv6; port 0 picks a free port) and
  // listens. HOST is resolved and the first of its addresses that can be
  // bound is used (one address: "localhost" is 127.0.0.1, not also ::1).
  static absl::StatusOr<std::unique_ptr<ConnectionAcceptor>> Listen(const std::string& host_port);
  // Stop().
  ~ConnectionAcceptor();
  ConnectionAcceptor(const ConnectionAcceptor&) = delete;
  ConnectionAcceptor& operator=(const ConnectionAcceptor&) = delete;

  // The bound port.
  int port() const { return port_; }

  // Starts accepting, handing each connection to `grpc_acceptor`, from the
  // gRPC server's builder (AddExternalConnectionAcceptor). `on_error`, if
  // set, is called on the accept thread for every failed accept (the
  // metrics count them). REQUIRES: that server has started (gRPC drops, and
  // leaks, a connection handed over before); called at most once.
  void Start(std::unique_ptr<grpc::experimental::ExternalConnectionAcceptor> grpc_acceptor,
             std::function<void()> on_error = nullptr);
  // Stops accepting, waits for the loop to end and closes the listening
  // socket: later connections are refused. Call before the gRPC server shuts
  // down. Idempotent.
  void Stop();

 private:
  ConnectionAcceptor() = default;
  void Run();
  // Waits up to `pause_ms` (forever if < 0) for the listener to be readable;
  // false once Stop() was called.
  bool WaitReadable(int pause_ms);

  int listen_fd_ = -1;
  int wake_read_fd_ = -1;  // Stop() writes to wake_write_fd_ to end the wait
  int wake_write_fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stopping_{false};
  std::unique_ptr<grpc::experimental::ExternalConnectionAcceptor> grpc_acceptor_;
  std::function<void()> on_error_;
  std::thread thread_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SECURITY_CONNECTION_ACCEPTOR_H_
