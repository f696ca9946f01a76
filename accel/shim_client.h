// ShimClient: one connection to one riskplan-fpga-shim, speaking the shim
// protocol (accel/shim_protocol.h). Every request has a deadline; any
// failure leaves the connection unusable (the byte stream may be out of
// step), and the caller reconnects.
//
// Errors:
//   DeadlineExceeded  no (complete) answer in time
//   Unavailable       cannot connect, or the connection closed or reset
//   DataLoss          a corrupt frame, or a reply that does not fit the
//                     request (wrong id, type, count, implausible values)
//   FailedPrecondition the shim speaks another protocol version
//   NotFound          EVAL named a blob the board does not hold
//                     (missing_blob() says which; the connection stays usable)
//   other             an ERROR from the shim, by its code
//
// Thread-compatible: one thread at a time (FpgaWorker owns one), except
// Interrupt(), which any thread may call to make a blocked call fail fast.
#ifndef RISKPLAN_ACCEL_SHIM_CLIENT_H_
#define RISKPLAN_ACCEL_SHIM_CLIENT_H_

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "accel/shim_protocol.h"
#include "net/net.h"
#include "net/tls_context.h"

namespace riskplan::accel {

struct ShimClientOptions {
  absl::Duration connect_timeout = absl::Seconds(2);
  absl::Duration hello_timeout = absl::Seconds(2);
  absl::Duration ping_timeout = absl::Seconds(1);
  // An EVAL of n sites may take eval_timeout + n * eval_timeout_per_site.
  absl::Duration eval_timeout = absl::Seconds(2);
  absl::Duration eval_timeout_per_site = absl::Microseconds(20);
  // An upload of b bytes may take upload_timeout + b / upload_min_bytes_per_s.
  absl::Duration upload_timeout = absl::Seconds(5);
  double upload_min_bytes_per_s = 10e6;
  // Upload chunk size (capped by the shim's max_payload_bytes).
  uint32_t upload_chunk_bytes = 4u << 20;
  std::string client_name = "riskplan";
  // TLS to the shim (net/tls_context.h); null: plaintext. The shim's
  // certificate must be for `tls_server_name`, or for the endpoint's host
  // when that is empty. The handshake has connect_timeout.
  std::shared_ptr<net::TlsContext> tls;
  std::string tls_server_name;
};

class ShimClient {
 public:
  // Connects and exchanges HELLO. Checks the reply: protocol version, a
  // valid number format, sane limits.
  static absl::StatusOr<std::unique_ptr<ShimClient>> Connect(const std::string& endpoint,
                                                             const ShimClientOptions& options);
  // The same over `socket`, already connected to a shim: exchanges HELLO and
  // checks the reply (`endpoint` only names the shim in messages). Connect is
  // ConnectTcp and then this; tests and fuzz targets give it one end of a
  // socketpair.
  static absl::StatusOr<std::unique_ptr<ShimClient>> Handshake(const std::string& endpoint,
                                                               net::Socket socket,
                                                               const ShimClientOptions& options);

  const HelloReply& hello() const { return hello_; }
  const std::string& endpoint() const { return endpoint_; }

  absl::Status Ping();
  // Uploads a blob in chunks (the last one completes it).
  absl::Status PutBlob(BlobKind kind, const BlobHash& hash, const std::string& bytes);
  // Evaluates at most hello().max_sites_per_eval sites.
  absl::StatusOr<EvalReply> Eval(const BlobHash& map, const BlobHash& kernels,
                                 std::span<const DeviceSite> sites);
  const BlobHash& missing_blob() const { return missing_blob_; }

  // Makes the call in progress (and every later one) fail with Unavailable.
  void Interrupt() { socket_.Shutdown(); }

 private:
  ShimClient(std::string endpoint, ShimClientOptions options, net::Socket socket)
      : endpoint_(std::move(endpoint)), options_(std::move(options)), socket_(std::move(socket)) {}

  // Sends a request and reads its reply, checking version, id and type.
  // An ERROR reply becomes a status.
  absl::Status Call(MessageType type, const std::string& payload, MessageType reply_type,
                    absl::Duration timeout, std::string* reply);

  const std::string endpoint_;
  const ShimClientOptions options_;
  net::Socket socket_;
  HelloReply hello_;
  uint64_t next_request_id_ = 1;
  BlobHash missing_blob_{};
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_CLIENT_H_
