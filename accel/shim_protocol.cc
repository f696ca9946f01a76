#include "accel/shim_protocol.h"

#include <openssl/evp.h>

#include <bit>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/byte_io.h"

namespace riskplan::accel {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the shim protocol's encoders copy little-endian integers as they are");

// CRC-32C (Castagnoli): the reflected polynomial 0x82F63B78 of the frame
// header's and payload's checksums (docs/shim-protocol.md, "Frames").
constexpr std::array<uint32_t, 256> MakeCrcTable() {
  std::array<uint32_t, 256> table{};
  for (uint32_t n = 0; n < 256; ++n) {
    uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0x82f63b78u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  return table;
}
constexpr std::array<uint32_t, 256> kCrcTable = MakeCrcTable();

absl::Status Malformed(absl::string_view what) {
  return absl::DataLossError(absl::StrCat("shim protocol: malformed ", what));
}

void PutHash(ByteWriter* w, const BlobHash& h) { w->PutBytes(h.data(), h.size()); }
bool GetHash(ByteReader* r, BlobHash* h) { return r->GetBytes(h->data(), h->size()); }

}  // namespace

absl::string_view MessageTypeName(MessageType type) {
  switch (type) {
    case MessageType::kHello:
      return "HELLO";
    case MessageType::kHelloReply:
      return "HELLO_REPLY";
    case MessageType::kPutBlob:
      return "PUT_BLOB";
    case MessageType::kPutBlobReply:
      return "PUT_BLOB_REPLY";
    case MessageType::kEval:
      return "EVAL";
    case MessageType::kEvalReply:
      return "EVAL_REPLY";
    case MessageType::kPing:
      return "PING";
    case MessageType::kPong:
      return "PONG";
    case MessageType::kError:
      return "ERROR";
  }
  return "UNKNOWN";
}

uint32_t Crc32c(const void* data, size_t size, uint32_t crc) {
  const auto* p = static_cast<const uint8_t*>(data);
  crc = ~crc;
  for (size_t n = 0; n < size; ++n) crc = kCrcTable[(crc ^ p[n]) & 0xff] ^ (crc >> 8);
  return ~crc;
}

std::string EncodeFrame(MessageType type, uint64_t request_id, absl::string_view payload,
                        uint16_t version) {
  std::string frame;
  frame.reserve(kFrameHeaderBytes + payload.size());
  ByteWriter w(&frame);
  w.Put<uint32_t>(kShimMagic);
  w.Put<uint16_t>(version);
  w.Put<uint16_t>(static_cast<uint16_t>(type));
  w.Put<uint64_t>(request_id);
  w.Put<uint32_t>(static_cast<uint32_t>(payload.size()));
  w.Put<uint32_t>(Crc32c(payload.data(), payload.size()));
  w.Put<uint32_t>(Crc32c(frame.data(), 24));  // header bytes 0-23
  w.Put<uint32_t>(0);
  frame.append(payload.data(), payload.size());
  return frame;
}

absl::Status DecodeHeader(const uint8_t bytes[kFrameHeaderBytes], uint32_t max_payload_bytes,
                          FrameHeader* header) {
  ByteReader r(absl::string_view(reinterpret_cast<const char*>(bytes), kFrameHeaderBytes));
  uint32_t magic = 0, header_crc = 0, reserved = 0;
  uint16_t type = 0;
  r.Get(&magic);
  r.Get(&header->version);
  r.Get(&type);
  r.Get(&header->request_id);
  r.Get(&header->payload_bytes);
  r.Get(&header->payload_crc);
  r.Get(&header_crc);
  r.Get(&reserved);
  // The protocol's order: magic and header CRC first (after a mismatch the
  // byte stream cannot be trusted, not even its length), then the length
  // against the limit; the payload CRC comes once it is read (CheckPayload).
  if (magic != kShimMagic) {
    return absl::DataLossError(absl::StrFormat("shim protocol: bad magic 0x%08x", magic));
  }
  if (header_crc != Crc32c(bytes, 24)) {
    return absl::DataLossError("shim protocol: header checksum mismatch");
  }
  header->type = static_cast<MessageType>(type);
  if (header->payload_bytes > max_payload_bytes || header->payload_bytes > kMaxPayloadBytes) {
    return absl::ResourceExhaustedError(
        absl::StrFormat("shim protocol: payload of %u bytes exceeds the limit of %u",
                        header->payload_bytes, std::min(max_payload_bytes, kMaxPayloadBytes)));
  }
  return absl::OkStatus();
}

absl::Status CheckPayload(const FrameHeader& header, absl::string_view payload) {
  if (payload.size() != header.payload_bytes ||
      Crc32c(payload.data(), payload.size()) != header.payload_crc) {
    return absl::DataLossError(absl::StrCat("shim protocol: ", MessageTypeName(header.type),
                                            " payload checksum mismatch"));
  }
  return absl::OkStatus();
}

BlobHash Sha256(absl::string_view data) {
  BlobHash hash{};
  unsigned int size = 0;
  EVP_Digest(data.data(), data.size(), hash.data(), &size, EVP_sha256(), nullptr);
  return hash;
}

std::string HashHex(const BlobHash& hash) {
  std::string hex;
  for (uint8_t b : hash) absl::StrAppendFormat(&hex, "%02x", b);
  return hex;
}

std::string EncodeHello(const HelloRequest& m) {
  std::string out;
  ByteWriter w(&out);
  w.PutString(m.client);
  return out;
}

absl::Status DecodeHello(absl::string_view payload, HelloRequest* m) {
  ByteReader r(payload);
  if (!r.GetString(&m->client) || !r.done()) return Malformed("HELLO");
  return absl::OkStatus();
}

std::string EncodeHelloReply(const HelloReply& m) {
  std::string out;
  ByteWriter w(&out);
  w.PutString(m.backend);
  w.PutString(m.device);
  w.PutString(m.firmware);
  w.Put<uint8_t>(static_cast<uint8_t>(m.format.weight_frac_bits));
  w.Put<uint8_t>(static_cast<uint8_t>(m.format.cell_bits));
  w.Put<uint8_t>(static_cast<uint8_t>(m.format.acc_bits));
  w.Put<uint8_t>(0);
  w.Put<uint32_t>(m.lanes);
  w.Put<uint32_t>(m.max_sites_per_eval);
  w.Put<uint32_t>(m.max_payload_bytes);
  w.Put<uint32_t>(m.max_kernel_side);
  w.Put<uint64_t>(m.store_bytes);
  w.Put<uint64_t>(m.clock_hz);
  return out;
}

absl::Status DecodeHelloReply(absl::string_view payload, HelloReply* m) {
  ByteReader r(payload);
  uint8_t wbits = 0, mbits = 0, abits = 0, reserved = 0;
  if (!r.GetString(&m->backend) || !r.GetString(&m->device) || !r.GetString(&m->firmware) ||
      !r.Get(&wbits) || !r.Get(&mbits) || !r.Get(&abits) || !r.Get(&reserved) ||
      !r.Get(&m->lanes) || !r.Get(&m->max_sites_per_eval) || !r.Get(&m->max_payload_bytes) ||
      !r.Get(&m->max_kernel_side) || !r.Get(&m->store_bytes) || !r.Get(&m->clock_hz) || !r.done()) {
    return Malformed("HELLO_REPLY");
  }
  m->format = NumberFormat{wbits, mbits, abits};
  return absl::OkStatus();
}

std::string EncodePutBlob(const PutBlobRequest& m) {
  std::string out;
  out.reserve(64 + m.data.size());
  ByteWriter w(&out);
  w.Put<uint16_t>(static_cast<uint16_t>(m.kind));
  w.Put<uint16_t>(0);
  PutHash(&w, m.hash);
  w.Put<uint64_t>(m.total_bytes);
  w.Put<uint64_t>(m.offset);
  w.Put<uint32_t>(static_cast<uint32_t>(m.data.size()));
  w.PutBytes(m.data.data(), m.data.size());
  return out;
}

absl::Status DecodePutBlob(absl::string_view payload, PutBlobRequest* m) {
  ByteReader r(payload);
  uint16_t kind = 0, reserved = 0;
  uint32_t size = 0;
  absl::string_view data;
  if (!r.Get(&kind) || !r.Get(&reserved) || !GetHash(&r, &m->hash) || !r.Get(&m->total_bytes) ||
      !r.Get(&m->offset) || !r.Get(&size) || !r.View(size, &data) || !r.done()) {
    return Malformed("PUT_BLOB");
  }
  m->kind = static_cast<BlobKind>(kind);
  m->data.assign(data.data(), data.size());
  return absl::OkStatus();
}

std::string EncodePutBlobReply(const PutBlobReply& m) {
  std::string out;
  ByteWriter w(&out);
  PutHash(&w, m.hash);
  w.Put<uint64_t>(m.received_bytes);
  w.Put<uint8_t>(m.complete ? 1 : 0);
  w.Put<uint8_t>(0);
  w.Put<uint16_t>(0);
  return out;
}

absl::Status DecodePutBlobReply(absl::string_view payload, PutBlobReply* m) {
  ByteReader r(payload);
  uint8_t complete = 0, r8 = 0;
  uint16_t r16 = 0;
  if (!GetHash(&r, &m->hash) || !r.Get(&m->received_bytes) || !r.Get(&complete) || !r.Get(&r8) ||
      !r.Get(&r16) || !r.done() || complete > 1) {
    return Malformed("PUT_BLOB_REPLY");
  }
  m->complete = complete == 1;
  return absl::OkStatus();
}

std::string EncodeEval(const EvalRequest& m) {
  std::string out;
  out.reserve(68 + 12 * m.sites.size());
  ByteWriter w(&out);
  PutHash(&w, m.map);
  PutHash(&w, m.kernels);
  w.Put<uint32_t>(static_cast<uint32_t>(m.sites.size()));
  for (const DeviceSite& s : m.sites) {
    w.Put<uint16_t>(s.height_bin);
    w.Put<uint16_t>(s.heading_bin);
    w.Put<int32_t>(s.impact_i);
    w.Put<int32_t>(s.impact_j);
  }
  return out;
}

absl::Status DecodeEval(absl::string_view payload, EvalRequest* m) {
  ByteReader r(payload);
  uint32_t count = 0;
  // The count is checked against the payload before anything is allocated
  // for it: a corrupt count cannot ask for more than the frame holds.
  if (!GetHash(&r, &m->map) || !GetHash(&r, &m->kernels) || !r.Get(&count) ||
      r.remaining() != size_t{count} * 12) {
    return Malformed("EVAL");
  }
  m->sites.resize(count);
  for (DeviceSite& s : m->sites) {
    r.Get(&s.height_bin);
    r.Get(&s.heading_bin);
    r.Get(&s.impact_i);
    r.Get(&s.impact_j);
  }
  return absl::OkStatus();
}

std::string EncodeEvalReply(const EvalReply& m) {
  std::string out;
  out.reserve(32 + 32 * m.impact.size());
  ByteWriter w(&out);
  w.Put<int32_t>(m.impact_scale);
  w.Put<int32_t>(m.shelter_scale);
  w.Put<uint64_t>(m.device_cycles);
  w.Put<uint64_t>(m.device_ns);
  w.Put<uint32_t>(static_cast<uint32_t>(m.impact.size()));
  w.Put<uint32_t>(4);  // 32-bit words per accumulator
  for (size_t n = 0; n < m.impact.size(); ++n) {
    uint32_t words[4];
    AccumulatorToWords(m.impact[n], words);
    w.PutBytes(words, sizeof(words));
    AccumulatorToWords(m.shelter[n], words);
    w.PutBytes(words, sizeof(words));
  }
  return out;
}

absl::Status DecodeEvalReply(absl::string_view payload, EvalReply* m) {
  ByteReader r(payload);
  uint32_t count = 0, words_per_acc = 0;
  // As in DecodeEval: the count is checked against the payload first.
  if (!r.Get(&m->impact_scale) || !r.Get(&m->shelter_scale) || !r.Get(&m->device_cycles) ||
      !r.Get(&m->device_ns) || !r.Get(&count) || !r.Get(&words_per_acc) || words_per_acc != 4 ||
      r.remaining() != size_t{count} * 32) {
    return Malformed("EVAL_REPLY");
  }
  m->impact.resize(count);
  m->shelter.resize(count);
  for (size_t n = 0; n < count; ++n) {
    uint32_t words[4];
    r.GetBytes(words, sizeof(words));
    m->impact[n] = AccumulatorFromWords(words);
    r.GetBytes(words, sizeof(words));
    m->shelter[n] = AccumulatorFromWords(words);
  }
  return absl::OkStatus();
}

std::string EncodePing(const PingMessage& m) {
  std::string out;
  ByteWriter w(&out);
  w.Put<uint64_t>(m.nonce);
  return out;
}

absl::Status DecodePing(absl::string_view payload, PingMessage* m) {
  ByteReader r(payload);
  if (!r.Get(&m->nonce) || !r.done()) return Malformed("PING");
  return absl::OkStatus();
}

std::string EncodeError(const ErrorMessage& m) {
  std::string out;
  ByteWriter w(&out);
  w.Put<uint32_t>(static_cast<uint32_t>(m.code));
  w.PutString(m.message);
  PutHash(&w, m.blob);
  return out;
}

absl::Status DecodeError(absl::string_view payload, ErrorMessage* m) {
  ByteReader r(payload);
  uint32_t code = 0;
  if (!r.Get(&code) || !r.GetString(&m->message) || !GetHash(&r, &m->blob) || !r.done()) {
    return Malformed("ERROR");
  }
  m->code = static_cast<ShimErrorCode>(code);
  return absl::OkStatus();
}

}  // namespace riskplan::accel
