// The input format of the two shim-protocol fuzz targets (and of their seed
// corpora): a sequence of records, each one frame on the wire. Frames are
// built by the target so that checksums and request ids come out right unless
// the record asks otherwise, which lets the fuzzer spend its time on
// payloads instead of on guessing CRC-32C values:
//
//   u8  flags        kRaw, kVersion, kRequestId, kFixBlobs, kBadCrc
//   u8  type         MessageType of the frame (ignored with kRaw)
//   u16 size         then `size` bytes: the payload (with kRaw: the whole
//                    frame as it goes on the wire, header and all)
//   u16 version      only with kVersion (else the current version)
//   u64 request_id   only with kRequestId (else the id the peer expects)
//
// kFixBlobs lets a record name blobs by content: the target replaces blob
// hashes it can compute (see each target).
#ifndef RISKPLAN_FUZZ_SHIM_RECORDS_H_
#define RISKPLAN_FUZZ_SHIM_RECORDS_H_

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/strings/string_view.h"
#include "accel/byte_io.h"
#include "accel/shim_protocol.h"
#include "fuzz/fuzz_support.h"
#include "net/net.h"

namespace riskplan::fuzz {

enum RecordFlags : uint8_t {
  kRaw = 1,
  kVersion = 2,
  kRequestId = 4,
  kFixBlobs = 8,
  kBadCrc = 16,
};

struct Record {
  uint8_t flags = 0;
  accel::MessageType type = accel::MessageType::kPing;
  std::string payload;  // or the raw frame
  uint16_t version = accel::kShimProtocolVersion;
  uint64_t request_id = 0;  // meaningful with kRequestId
};

inline std::vector<Record> ReadRecords(InputReader& in) {
  std::vector<Record> records;
  while (!in.done()) {
    Record r;
    r.flags = in.Get<uint8_t>();
    r.type = static_cast<accel::MessageType>(in.Get<uint8_t>());
    r.payload = std::string(in.Sized());
    if (r.flags & kVersion) r.version = in.Get<uint16_t>();
    if (r.flags & kRequestId) r.request_id = in.Get<uint64_t>();
    records.push_back(std::move(r));
  }
  return records;
}

// The record's frame; `id` is used unless the record gives its own.
inline std::string FrameOf(const Record& r, uint64_t id) {
  if (r.flags & kRaw) return r.payload;
  std::string frame = accel::EncodeFrame(r.type, (r.flags & kRequestId) ? r.request_id : id,
                                         r.payload, r.version);
  if (r.flags & kBadCrc) frame[20] = static_cast<char>(frame[20] ^ 1);  // payload CRC
  return frame;
}

// Seed corpora are written with these (fuzz/make_seeds.cc).
inline void AppendRecord(std::string* out, const Record& r) {
  accel::ByteWriter w(out);
  w.Put<uint8_t>(r.flags);
  w.Put<uint8_t>(static_cast<uint8_t>(r.type));
  w.Put<uint16_t>(static_cast<uint16_t>(r.payload.size()));
  w.PutBytes(r.payload.data(), r.payload.size());
  if (r.flags & kVersion) w.Put<uint16_t>(r.version);
  if (r.flags & kRequestId) w.Put<uint64_t>(r.request_id);
}

// A connected pair of non-blocking stream sockets (a socketpair: the
// protocol's code reads and writes it as it would a TCP connection).
inline std::pair<net::Socket, net::Socket> SocketPair() {
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_STREAM, 0, fds) != 0) Fail("socketpair");
  for (int fd : fds) fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
  return {net::Socket(fds[0]), net::Socket(fds[1])};
}

// Writes as much of `bytes` as the socket takes without blocking, then
// closes the sending side: the peer reads what was written, then end of
// stream. (The socket buffer holds far more than a fuzz input.)
inline void SendAndClose(const net::Socket& socket, absl::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = send(socket.fd(), bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n <= 0) break;
    bytes.remove_prefix(static_cast<size_t>(n));
  }
  shutdown(socket.fd(), SHUT_WR);
}

// Everything waiting on a non-blocking socket.
inline std::string ReceiveAll(const net::Socket& socket) {
  std::string out;
  char buffer[1 << 14];
  ssize_t n;
  while ((n = recv(socket.fd(), buffer, sizeof buffer, 0)) > 0) out.append(buffer, n);
  return out;
}

// Splits one whole, well-formed frame off the front of `bytes` (header,
// checksums, the current version), or fails the run naming what is wrong:
// what a peer sends must always be a frame the other side can read.
inline absl::string_view TakeFrame(absl::string_view* bytes, accel::FrameHeader* header) {
  if (bytes->size() < accel::kFrameHeaderBytes) Fail("a frame shorter than its header");
  if (!accel::DecodeHeader(reinterpret_cast<const uint8_t*>(bytes->data()),
                           accel::kMaxPayloadBytes, header)
           .ok()) {
    Fail("a frame whose header does not decode");
  }
  if (header->version != accel::kShimProtocolVersion) Fail("a frame of another version");
  if (bytes->size() - accel::kFrameHeaderBytes < header->payload_bytes) Fail("a truncated frame");
  const absl::string_view payload = bytes->substr(accel::kFrameHeaderBytes, header->payload_bytes);
  if (!accel::CheckPayload(*header, payload).ok()) Fail("a frame whose payload CRC is wrong");
  bytes->remove_prefix(accel::kFrameHeaderBytes + header->payload_bytes);
  return payload;
}

}  // namespace riskplan::fuzz

#endif  // RISKPLAN_FUZZ_SHIM_RECORDS_H_
