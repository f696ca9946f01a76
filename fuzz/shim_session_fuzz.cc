// Fuzz target: the shim's side of the shim protocol, the board's view of an
// untrusted connection: frames read off a socket (ReadFrame), every request
// type decoded and handled by a ShimSession over the software model device
// (HELLO, PING, PUT_BLOB uploads with blob checks and quantisation, EVAL on
// the installed blobs), and the shim's own replies.
//
// Input: records (fuzz/shim_records.h), sent in order on one connection
// whose requests the shim serves as ShimServer::Serve does, until the
// connection ends or the shim closes it. Request ids count from 1. With
// kFixBlobs, a PUT_BLOB whose chunk is the whole blob gets the blob's SHA-256
// as its hash, and an EVAL names the last map and kernels blobs so fixed.
//
// Properties: every reply is one well-formed frame of the current version
// with the request's id, of the request's reply type or ERROR, whose payload
// decodes and encodes back to the same bytes; a PONG carries the PING's
// nonce; a PUT_BLOB reply counts the bytes held; an EVAL reply has one
// result per site.
#include <cstdint>
#include <string>

#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "accel/blobs.h"
#include "accel/frame_io.h"
#include "accel/shim/device.h"
#include "accel/shim/shim_session.h"
#include "accel/shim_protocol.h"
#include "fuzz/fuzz_support.h"
#include "fuzz/shim_records.h"

namespace riskplan::fuzz {
namespace {

using namespace riskplan::accel;

// Small limits, so that every limit can be reached from a small input.
ShimLimits FuzzLimits() {
  ShimLimits limits;
  limits.max_sites_per_eval = 512;
  limits.max_payload_bytes = 64u << 10;
  limits.store_bytes = 1u << 20;
  limits.max_blob_bytes = 256u << 10;
  return limits;
}

// Encode(Decode(payload)) == payload for each reply type, and the reply's own
// consistency with the request.
void CheckReply(const FrameHeader& request, absl::string_view request_payload,
                absl::string_view reply_frame) {
  FrameHeader header;
  absl::string_view rest = reply_frame;
  const absl::string_view payload = TakeFrame(&rest, &header);
  if (!rest.empty()) Fail("a reply of more than one frame");
  if (header.request_id != request.request_id) Fail("a reply with another request's id");
  switch (header.type) {
    case MessageType::kError: {
      ErrorMessage m;
      if (!DecodeError(payload, &m).ok() || EncodeError(m) != payload) Fail("ERROR");
      return;
    }
    case MessageType::kHelloReply: {
      HelloReply m;
      if (request.type != MessageType::kHello) Fail("HELLO_REPLY to another request");
      if (!DecodeHelloReply(payload, &m).ok() || EncodeHelloReply(m) != payload) {
        Fail("HELLO_REPLY");
      }
      return;
    }
    case MessageType::kPong: {
      PingMessage ping, pong;
      if (request.type != MessageType::kPing) Fail("PONG to another request");
      if (!DecodePing(payload, &pong).ok() || EncodePing(pong) != payload) Fail("PONG");
      if (!DecodePing(request_payload, &ping).ok() || ping.nonce != pong.nonce) {
        Fail("PONG with another nonce");
      }
      return;
    }
    case MessageType::kPutBlobReply: {
      PutBlobRequest put;
      PutBlobReply m;
      if (request.type != MessageType::kPutBlob) Fail("PUT_BLOB_REPLY to another request");
      if (!DecodePutBlobReply(payload, &m).ok() || EncodePutBlobReply(m) != payload) {
        Fail("PUT_BLOB_REPLY");
      }
      if (!DecodePutBlob(request_payload, &put).ok() || m.hash != put.hash ||
          m.received_bytes != put.offset + put.data.size() ||
          m.complete != (m.received_bytes == put.total_bytes)) {
        Fail("PUT_BLOB_REPLY that does not acknowledge the chunk");
      }
      return;
    }
    case MessageType::kEvalReply: {
      EvalRequest eval;
      EvalReply m;
      if (request.type != MessageType::kEval) Fail("EVAL_REPLY to another request");
      if (!DecodeEvalReply(payload, &m).ok() || EncodeEvalReply(m) != payload) {
        Fail("EVAL_REPLY");
      }
      if (!DecodeEval(request_payload, &eval).ok() || m.impact.size() != eval.sites.size()) {
        Fail("EVAL_REPLY with another number of results");
      }
      return;
    }
    default:
      Fail("a reply of a type the shim never sends");
  }
}

// Applies kFixBlobs to a request payload.
std::string FixBlobs(const Record& r, BlobHash* map, BlobHash* kernels) {
  if (r.type == MessageType::kPutBlob) {
    PutBlobRequest put;
    if (!DecodePutBlob(r.payload, &put).ok() || put.offset != 0 ||
        put.data.size() != put.total_bytes) {
      return r.payload;
    }
    put.hash = Sha256(put.data);
    (put.kind == BlobKind::kKernels ? *kernels : *map) = put.hash;
    return EncodePutBlob(put);
  }
  if (r.type == MessageType::kEval) {
    EvalRequest eval;
    if (!DecodeEval(r.payload, &eval).ok()) return r.payload;
    eval.map = *map;
    eval.kernels = *kernels;
    return EncodeEval(eval);
  }
  return r.payload;
}

void Run(const uint8_t* data, size_t size) {
  InputReader in(data, size);
  std::vector<Record> records = ReadRecords(in);
  std::string stream;
  BlobHash map{}, kernels{};
  for (size_t k = 0; k < records.size(); ++k) {
    Record& r = records[k];
    if ((r.flags & (kFixBlobs | kRaw)) == kFixBlobs) r.payload = FixBlobs(r, &map, &kernels);
    stream += FrameOf(r, k + 1);
  }
  auto [client, shim] = SocketPair();
  SendAndClose(client, stream);

  ModelDevice device(NumberFormat::Board());
  const ShimLimits limits = FuzzLimits();
  BlobStore store(device.info().format, static_cast<int>(device.info().max_kernel_side),
                  limits.store_bytes);
  ShimContext context;
  context.device = &device;
  context.store = &store;
  context.limits = limits;
  ShimSession session(&context);
  std::string payload;
  while (true) {
    FrameHeader header;
    const absl::Status s =
        ReadFrame(shim, limits.max_payload_bytes, absl::Now() + absl::Seconds(10), &header, &payload);
    if (!s.ok()) {
      // The stream is out of step; ShimServer answers a corrupt or oversized
      // frame with this ERROR and closes.
      if (absl::IsDataLoss(s) || absl::IsResourceExhausted(s)) {
        FrameHeader none;
        none.request_id = 0;
        CheckReply(none, "", ShimSession::ErrorFrame(0, ShimErrorCode::kMalformed, s.message()));
      } else if (!absl::IsUnavailable(s)) {
        Fail(s.ToString());  // end of stream is the only other way out
      }
      return;
    }
    bool close = false;
    CheckReply(header, payload, session.Handle(header, payload, &close));
    if (close) return;
  }
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  riskplan::fuzz::Run(data, size);
  return 0;
}
