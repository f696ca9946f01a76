#include "accel/shim_client.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/frame_io.h"

namespace riskplan::accel {
namespace {

// Largest reply the client accepts: an EVAL reply of the most sites the
// protocol can carry.
constexpr uint32_t kMaxReplyBytes = kMaxPayloadBytes;

absl::Status FromShimError(const ErrorMessage& e, absl::string_view endpoint) {
  const std::string text = absl::StrCat("shim ", endpoint, ": ", e.message);
  switch (e.code) {
    case ShimErrorCode::kVersionMismatch:
      return absl::FailedPreconditionError(text);
    case ShimErrorCode::kUnknownBlob:
      return absl::NotFoundError(text);
    case ShimErrorCode::kMalformed:
    case ShimErrorCode::kBlobRejected:
      return absl::InvalidArgumentError(text);
    case ShimErrorCode::kLimitExceeded:
      return absl::ResourceExhaustedError(text);
    case ShimErrorCode::kDeviceError:
      return absl::UnavailableError(text);
    case ShimErrorCode::kInternal:
      return absl::InternalError(text);
  }
  return absl::UnknownError(text);
}

}  // namespace

absl::StatusOr<std::unique_ptr<ShimClient>> ShimClient::Connect(const std::string& endpoint,
                                                                const ShimClientOptions& options) {
  const absl::Time connect_deadline = absl::Now() + options.connect_timeout;
  absl::StatusOr<net::Socket> socket = net::ConnectTcp(endpoint, connect_deadline);
  if (!socket.ok()) return socket.status();
  if (options.tls != nullptr) {
    std::string name = options.tls_server_name;
    if (name.empty()) {
      int port = 0;
      if (absl::Status s = net::SplitHostPort(endpoint, &name, &port); !s.ok()) return s;
    }
    if (absl::Status s = options.tls->Connect(&*socket, name, connect_deadline); !s.ok()) {
      return absl::Status(s.code(), absl::StrCat("shim ", endpoint, ": ", s.message()));
    }
  }
  return Handshake(endpoint, *std::move(socket), options);
}

absl::StatusOr<std::unique_ptr<ShimClient>> ShimClient::Handshake(
    const std::string& endpoint, net::Socket socket, const ShimClientOptions& options) {
  auto client = std::unique_ptr<ShimClient>(new ShimClient(endpoint, options, std::move(socket)));
  std::string reply;
  if (absl::Status s = client->Call(MessageType::kHello, EncodeHello({options.client_name}),
                                    MessageType::kHelloReply, options.hello_timeout, &reply);
      !s.ok()) {
    return s;
  }
  if (absl::Status s = DecodeHelloReply(reply, &client->hello_); !s.ok()) return s;
  const HelloReply& h = client->hello_;
  if (absl::Status s = h.format.Validate(); !s.ok()) {
    return absl::DataLossError(absl::StrCat("shim ", endpoint, ": HELLO: ", s.message()));
  }
  if (h.lanes == 0 || h.max_sites_per_eval == 0 || h.max_payload_bytes < 4096 ||
      h.max_kernel_side == 0) {
    return absl::DataLossError(absl::StrCat("shim ", endpoint, ": HELLO announces zero limits"));
  }
  return client;
}

absl::Status ShimClient::Call(MessageType type, const std::string& payload, MessageType reply_type,
                              absl::Duration timeout, std::string* reply) {
  const absl::Time deadline = absl::Now() + timeout;
  const uint64_t id = next_request_id_++;
  const std::string what = absl::StrCat("shim ", endpoint_, ": ", MessageTypeName(type));
  if (absl::Status s = net::SendAll(socket_, EncodeFrame(type, id, payload), deadline); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat(what, ": ", s.message()));
  }
  FrameHeader header;
  if (absl::Status s = ReadFrame(socket_, kMaxReplyBytes, deadline, &header, reply); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat(what, ": ", s.message()));
  }
  if (header.version != kShimProtocolVersion) {
    // The ERROR layout is the same in every version, so read it if it is one.
    ErrorMessage e;
    std::string detail;
    if (header.type == MessageType::kError && DecodeError(*reply, &e).ok()) {
      detail = absl::StrCat(": ", e.message);
    }
    return absl::FailedPreconditionError(
        absl::StrFormat("%s: the shim speaks protocol version %d, this client %d%s", what,
                        header.version, kShimProtocolVersion, detail));
  }
  // One request at a time (no pipelining): a reply to any other request
  // means the stream is out of step.
  if (header.request_id != id) {
    return absl::DataLossError(
        absl::StrFormat("%s: reply to request %d, expected %d", what, header.request_id, id));
  }
  if (header.type == MessageType::kError) {
    ErrorMessage e;
    if (absl::Status s = DecodeError(*reply, &e); !s.ok()) return s;
    if (e.code == ShimErrorCode::kUnknownBlob) missing_blob_ = e.blob;
    return FromShimError(e, endpoint_);
  }
  if (header.type != reply_type) {
    return absl::DataLossError(
        absl::StrCat(what, ": unexpected reply ", MessageTypeName(header.type)));
  }
  return absl::OkStatus();
}

absl::Status ShimClient::Ping() {
  const uint64_t nonce = next_request_id_ * 0x9e3779b97f4a7c15ULL;
  std::string reply;
  if (absl::Status s = Call(MessageType::kPing, EncodePing({nonce}), MessageType::kPong,
                            options_.ping_timeout, &reply);
      !s.ok()) {
    return s;
  }
  PingMessage pong;
  if (absl::Status s = DecodePing(reply, &pong); !s.ok()) return s;
  if (pong.nonce != nonce) return absl::DataLossError("shim " + endpoint_ + ": PONG nonce differs");
  return absl::OkStatus();
}

absl::Status ShimClient::PutBlob(BlobKind kind, const BlobHash& hash, const std::string& bytes) {
  // Each chunk leaves 1 KiB of the shim's payload limit for PUT_BLOB's own
  // fields (56 bytes); Handshake refused a limit under 4 KiB, so the
  // subtraction cannot wrap.
  const uint32_t chunk = std::max<uint32_t>(
      1024, std::min(options_.upload_chunk_bytes, hello_.max_payload_bytes - 1024));
  uint64_t offset = 0;
  do {
    PutBlobRequest request;
    request.kind = kind;
    request.hash = hash;
    request.total_bytes = bytes.size();
    request.offset = offset;
    const size_t n = std::min<size_t>(chunk, bytes.size() - offset);
    request.data.assign(bytes.data() + offset, n);
    const absl::Duration timeout =
        options_.upload_timeout + absl::Seconds(n / options_.upload_min_bytes_per_s);
    std::string reply;
    if (absl::Status s = Call(MessageType::kPutBlob, EncodePutBlob(request),
                              MessageType::kPutBlobReply, timeout, &reply);
        !s.ok()) {
      return s;
    }
    PutBlobReply ack;
    if (absl::Status s = DecodePutBlobReply(reply, &ack); !s.ok()) return s;
    offset += n;
    if (ack.hash != hash || ack.received_bytes != offset ||
        ack.complete != (offset == bytes.size())) {
      return absl::DataLossError(
          absl::StrFormat("shim %s: PUT_BLOB acknowledged %d bytes (complete %d), sent %d of %d",
                          endpoint_, ack.received_bytes, ack.complete, offset, bytes.size()));
    }
  } while (offset < bytes.size());
  return absl::OkStatus();
}

absl::StatusOr<EvalReply> ShimClient::Eval(const BlobHash& map, const BlobHash& kernels,
                                           std::span<const DeviceSite> sites) {
  EvalRequest request;
  request.map = map;
  request.kernels = kernels;
  request.sites.assign(sites.begin(), sites.end());
  const absl::Duration timeout =
      options_.eval_timeout + options_.eval_timeout_per_site * static_cast<double>(sites.size());
  std::string reply;
  if (absl::Status s =
          Call(MessageType::kEval, EncodeEval(request), MessageType::kEvalReply, timeout, &reply);
      !s.ok()) {
    return s;
  }
  EvalReply result;
  if (absl::Status s = DecodeEvalReply(reply, &result); !s.ok()) return s;
  if (result.impact.size() != sites.size()) {
    return absl::DataLossError(absl::StrFormat("shim %s: EVAL of %d sites answered %d", endpoint_,
                                               sites.size(), result.impact.size()));
  }
  return result;
}

}  // namespace riskplan::accel
