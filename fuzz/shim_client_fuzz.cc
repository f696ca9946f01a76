// Fuzz target: the server's side of the shim protocol, a ShimClient reading
// the replies of an untrusted board: the HELLO exchange and its checks,
// PING, chunked PUT_BLOB uploads and their acknowledgements, EVAL and its
// results, ERROR replies (a missing blob), and the known-answer probe that
// FpgaWorker runs on a board before trusting it (RunKnownAnswer).
//
// Input:
//   u8  n            then n operation bytes (at most 16 are used), op & 3:
//                    0 PING, 1 PUT_BLOB of the test blob (op & 4: as a
//                    kernels blob), 2 EVAL of op >> 2 sites, 3 known answer
//   u16 blob_size    the test blob: blob_size pseudo-random bytes
//   records          the shim's replies (fuzz/shim_records.h), in order
// The replies are all on the connection before the client starts; the k-th
// gets request id k (the id the client's k-th request has) unless it gives
// its own. With kFixBlobs, the hash in a PUT_BLOB reply or an ERROR is
// replaced by the test blob's (first payload byte % 3 == 0), the known-answer
// map's (1) or the known-answer kernels' (2).
//
// Properties: every request the client sends is one well-formed frame of the
// current version with ids 1, 2, 3, ... in order; an EVAL that succeeds has
// one result per site. After an operation fails (other than NotFound, a
// missing blob) the client, like FpgaWorker, uses the connection no more.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "accel/blobs.h"
#include "accel/known_answer.h"
#include "accel/shim_client.h"
#include "accel/shim_protocol.h"
#include "fuzz/fuzz_support.h"
#include "fuzz/shim_records.h"
#include "net/net.h"

namespace riskplan::fuzz {
namespace {

using namespace riskplan::accel;

std::string TestBlob(size_t size) {
  std::string bytes(size, '\0');
  uint32_t x = 2463534242u;
  for (char& c : bytes) {
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    c = static_cast<char>(x);
  }
  return bytes;
}

std::vector<DeviceSite> TestSites(size_t n) {
  std::vector<DeviceSite> sites;
  for (size_t k = 0; k < n; ++k) {
    sites.push_back(DeviceSite{static_cast<uint16_t>(1 + k % 3), static_cast<uint16_t>(k % 4),
                               static_cast<int32_t>(k * 7 % 40), static_cast<int32_t>(k * 5 % 28)});
  }
  return sites;
}

// Applies kFixBlobs to a reply payload.
std::string FixBlobs(const Record& r, const BlobHash& test_blob) {
  if (r.payload.empty()) return r.payload;
  const KnownAnswerBatch& known = GetKnownAnswerBatch();
  const int which = static_cast<uint8_t>(r.payload[0]) % 3;
  const BlobHash& hash = which == 0 ? test_blob : which == 1 ? known.map.hash : known.kernels.hash;
  if (r.type == MessageType::kPutBlobReply) {
    PutBlobReply m;
    if (!DecodePutBlobReply(r.payload, &m).ok()) return r.payload;
    m.hash = hash;
    return EncodePutBlobReply(m);
  }
  if (r.type == MessageType::kError) {
    ErrorMessage m;
    if (!DecodeError(r.payload, &m).ok()) return r.payload;
    m.blob = hash;
    return EncodeError(m);
  }
  return r.payload;
}

// Reads what the client has sent so far and checks every frame of it.
void CheckRequests(const net::Socket& shim, uint64_t* next_id) {
  const std::string sent = ReceiveAll(shim);
  absl::string_view rest = sent;
  while (!rest.empty()) {
    FrameHeader header;
    const absl::string_view payload = TakeFrame(&rest, &header);
    if (header.request_id != (*next_id)++) Fail("request ids out of order");
    bool ok = false;
    switch (header.type) {
      case MessageType::kHello: {
        HelloRequest m;
        ok = DecodeHello(payload, &m).ok();
        break;
      }
      case MessageType::kPing: {
        PingMessage m;
        ok = DecodePing(payload, &m).ok();
        break;
      }
      case MessageType::kPutBlob: {
        PutBlobRequest m;
        ok = DecodePutBlob(payload, &m).ok() && m.offset + m.data.size() <= m.total_bytes;
        break;
      }
      case MessageType::kEval: {
        EvalRequest m;
        ok = DecodeEval(payload, &m).ok();
        break;
      }
      default:
        break;
    }
    if (!ok) Fail("a request that does not decode");
  }
}

void Run(const uint8_t* data, size_t size) {
  InputReader in(data, size);
  const uint8_t op_count = in.Get<uint8_t>();
  const std::string_view ops = in.Bytes(std::min<size_t>(op_count, 16));
  const std::string blob = TestBlob(in.Get<uint16_t>() % (16u << 10));
  const BlobHash blob_hash = Sha256(blob);
  std::vector<Record> records = ReadRecords(in);
  std::string replies;
  for (size_t k = 0; k < records.size(); ++k) {
    Record& r = records[k];
    if ((r.flags & (kFixBlobs | kRaw)) == kFixBlobs) r.payload = FixBlobs(r, blob_hash);
    replies += FrameOf(r, k + 1);
  }
  auto [client_end, shim] = SocketPair();
  SendAndClose(shim, replies);

  ShimClientOptions options;
  options.upload_chunk_bytes = 1024;  // uploads of several chunks from small inputs
  options.client_name = "fuzz";
  uint64_t next_id = 1;
  absl::StatusOr<std::unique_ptr<ShimClient>> client =
      ShimClient::Handshake("fuzz-shim", std::move(client_end), options);
  CheckRequests(shim, &next_id);
  if (!client.ok()) return;
  for (const char op : ops) {
    absl::Status s;
    switch (op & 3) {
      case 0:
        s = (*client)->Ping();
        break;
      case 1:
        s = (*client)->PutBlob((op & 4) ? BlobKind::kKernels : BlobKind::kMap, blob_hash, blob);
        break;
      case 2: {
        const std::vector<DeviceSite> sites = TestSites(static_cast<uint8_t>(op) >> 2);
        absl::StatusOr<EvalReply> reply =
            (*client)->Eval(blob_hash, GetKnownAnswerBatch().kernels.hash, sites);
        if (reply.ok() && reply->impact.size() != sites.size()) Fail("EVAL results per site");
        s = reply.status();
        break;
      }
      default:
        s = RunKnownAnswer(**client);
        break;
    }
    CheckRequests(shim, &next_id);
    if (!s.ok() && !absl::IsNotFound(s)) return;
  }
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  riskplan::fuzz::Run(data, size);
  return 0;
}
