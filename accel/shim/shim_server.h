// ShimServer: riskplan-fpga-shim's TCP front: a listener, and one thread per
// connection running a ShimSession. Connections that send nothing for
// `idle_timeout` are closed; a frame whose header is corrupt gets an ERROR
// (request id 0) and the connection is closed, since the stream can no
// longer be trusted.
//
// Thread-safe: Start() once, then Stop() from any thread (also from a signal
// watcher); the destructor stops.
#ifndef RISKPLAN_ACCEL_SHIM_SHIM_SERVER_H_
#define RISKPLAN_ACCEL_SHIM_SHIM_SERVER_H_

#include <functional>
#include <list>
#include <memory>
#include <string>
#include <thread>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "accel/shim/device.h"
#include "accel/shim/shim_session.h"
#include "net/net.h"
#include "net/tls_context.h"

namespace riskplan::accel {

struct ShimServerOptions {
  ShimLimits limits;
  absl::Duration idle_timeout = absl::Minutes(10);
  int max_connections = 64;
  // TLS on every connection (net/tls_context.h); null: plaintext. With a
  // client CA the shim refuses a server whose certificate it cannot verify.
  std::shared_ptr<net::TlsContext> tls;
  absl::Duration handshake_timeout = absl::Seconds(10);
  // Called on a connection's thread for every refused handshake and every
  // certificate reload (the daemon prints them); may be null.
  std::function<void(const std::string&)> on_tls_event;
};

class ShimServer {
 public:
  // Takes the device.
  ShimServer(std::unique_ptr<EwmmDevice> device, const ShimServerOptions& options);
  ~ShimServer();

  // Listens on "host:port" (port 0 picks one) and starts accepting. Returns
  // the bound "host:port".
  absl::StatusOr<std::string> Start(const std::string& listen);
  // Stops accepting, closes every connection, joins the threads.
  void Stop();

  const ShimContext& context() const { return context_; }
  uint64_t connections_accepted() const;

 private:
  struct Connection {
    net::Socket socket;
    std::thread thread;
    bool finished = false;
  };
  void AcceptLoop();
  void Serve(Connection* connection);

  std::unique_ptr<EwmmDevice> device_;
  std::unique_ptr<BlobStore> store_;
  const ShimServerOptions options_;
  ShimContext context_;
  net::Socket listener_;
  std::thread accept_thread_;
  mutable absl::Mutex mu_;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::list<Connection> connections_ ABSL_GUARDED_BY(mu_);
  uint64_t accepted_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_SHIM_SERVER_H_
