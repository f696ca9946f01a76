// The shim protocol between a RiskEngine's FPGA worker (client) and the
// riskplan-fpga-shim daemon on a board (docs/shim-protocol.md is the
// reference; this header is its C++ form).
//
// A connection carries frames: a 32-byte header and a payload, all integers
// little-endian.
//   0  u32 magic         "RPSH" (0x48535052)
//   4  u16 version       kShimProtocolVersion
//   6  u16 type          MessageType
//   8  u64 request_id    chosen by the client, echoed by the shim
//   16 u32 payload_bytes at most the receiver's limit
//   20 u32 payload_crc   CRC-32C of the payload
//   24 u32 header_crc    CRC-32C of bytes 0..23
//   28 u32 reserved      0
// The client sends one request at a time and waits for the reply with the
// same request id (or ERROR). Payload layouts are in the Encode/Decode
// functions below and in the document.
#ifndef RISKPLAN_ACCEL_SHIM_PROTOCOL_H_
#define RISKPLAN_ACCEL_SHIM_PROTOCOL_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "accel/fixed_point.h"

namespace riskplan::accel {

inline constexpr uint32_t kShimMagic = 0x48535052;  // bytes "RPSH"
inline constexpr uint16_t kShimProtocolVersion = 1;
inline constexpr size_t kFrameHeaderBytes = 32;
// No frame of this protocol may exceed this payload, whatever a peer says.
inline constexpr uint32_t kMaxPayloadBytes = 64u << 20;

enum class MessageType : uint16_t {
  kHello = 1,
  kHelloReply = 2,
  kPutBlob = 3,
  kPutBlobReply = 4,
  kEval = 5,
  kEvalReply = 6,
  kPing = 7,
  kPong = 8,
  kError = 15,
};
absl::string_view MessageTypeName(MessageType type);

// CRC-32C (Castagnoli), as used by iSCSI and ext4.
uint32_t Crc32c(const void* data, size_t size, uint32_t crc = 0);

struct FrameHeader {
  uint16_t version = kShimProtocolVersion;
  MessageType type = MessageType::kPing;
  uint64_t request_id = 0;
  uint32_t payload_bytes = 0;
  uint32_t payload_crc = 0;
};

// A whole frame (header and payload) ready to send.
std::string EncodeFrame(MessageType type, uint64_t request_id, absl::string_view payload,
                        uint16_t version = kShimProtocolVersion);
// Parses and checks a header: magic, header CRC, payload size within
// `max_payload_bytes`. Any version is accepted here (the caller decides).
// DataLoss for a corrupt header, ResourceExhausted for an oversized payload.
absl::Status DecodeHeader(const uint8_t bytes[kFrameHeaderBytes], uint32_t max_payload_bytes,
                          FrameHeader* header);
// DataLoss when the payload does not match its CRC.
absl::Status CheckPayload(const FrameHeader& header, absl::string_view payload);

// A SHA-256 digest: the name of a blob on the board.
using BlobHash = std::array<uint8_t, 32>;
BlobHash Sha256(absl::string_view data);
std::string HashHex(const BlobHash& hash);

enum class BlobKind : uint16_t {
  kMap = 1,      // density and shelter layers (MapBlob)
  kKernels = 2,  // an impact table's kernels (KernelsBlob)
};

enum class ShimErrorCode : uint32_t {
  kVersionMismatch = 1,  // the frame's version is not spoken; the shim closes
  kMalformed = 2,        // a payload that does not parse; the shim closes
  kUnknownBlob = 3,      // EVAL names a blob the board does not hold: upload it
  kBlobRejected = 4,     // PUT_BLOB: bad hash, size or contents
  kLimitExceeded = 5,    // too many sites, too large a blob, store full
  kDeviceError = 6,      // the device failed (the request may be retried)
  kInternal = 7,
};

// HELLO: client -> shim.
struct HelloRequest {
  std::string client;  // free text, e.g. "riskplan-server 0.1 pid 1234"
};
// HELLO reply: what the board is and what it accepts.
struct HelloReply {
  std::string backend;   // "model", "mmio", "verilator"
  std::string device;    // identity of the device instance (serial, path, ...)
  std::string firmware;  // component/bitstream version, or the model's
  NumberFormat format;
  uint32_t lanes = 1;               // configurations accumulated in parallel
  uint32_t max_sites_per_eval = 0;  // largest EVAL
  uint32_t max_payload_bytes = 0;   // largest frame payload it accepts
  uint32_t max_kernel_side = 0;     // largest kernel side (cells)
  uint64_t store_bytes = 0;         // room for blobs
  uint64_t clock_hz = 0;            // device clock (0 when not meaningful)
};

// PUT_BLOB: one chunk of a blob; the last chunk completes it.
struct PutBlobRequest {
  BlobKind kind = BlobKind::kMap;
  BlobHash hash{};
  uint64_t total_bytes = 0;
  uint64_t offset = 0;
  std::string data;
};
struct PutBlobReply {
  BlobHash hash{};
  uint64_t received_bytes = 0;  // contiguous bytes held so far
  bool complete = false;        // verified and installed
};

// One kernel site as the board sees it.
struct DeviceSite {
  uint16_t height_bin = 0;  // 1-based, as in ImpactTable
  uint16_t heading_bin = 0;
  int32_t impact_i = 0;
  int32_t impact_j = 0;
};
struct EvalRequest {
  BlobHash map{};
  BlobHash kernels{};
  std::vector<DeviceSite> sites;
};
// The raw accumulators, in the order of the sites; values are
// acc * 2^-impact_scale and acc * 2^-shelter_scale.
struct EvalReply {
  int32_t impact_scale = 0;
  int32_t shelter_scale = 0;
  uint64_t device_cycles = 0;  // cycles the device spent (0 when unknown)
  uint64_t device_ns = 0;      // wall time the device spent
  std::vector<Accumulator> impact;
  std::vector<Accumulator> shelter;
};

struct PingMessage {
  uint64_t nonce = 0;
};

struct ErrorMessage {
  ShimErrorCode code = ShimErrorCode::kInternal;
  std::string message;
  BlobHash blob{};  // kUnknownBlob: which one
};

std::string EncodeHello(const HelloRequest& m);
std::string EncodeHelloReply(const HelloReply& m);
std::string EncodePutBlob(const PutBlobRequest& m);
std::string EncodePutBlobReply(const PutBlobReply& m);
std::string EncodeEval(const EvalRequest& m);
std::string EncodeEvalReply(const EvalReply& m);
std::string EncodePing(const PingMessage& m);
std::string EncodeError(const ErrorMessage& m);

// Each fails with DataLoss when the payload is short, long or inconsistent.
absl::Status DecodeHello(absl::string_view payload, HelloRequest* m);
absl::Status DecodeHelloReply(absl::string_view payload, HelloReply* m);
absl::Status DecodePutBlob(absl::string_view payload, PutBlobRequest* m);
absl::Status DecodePutBlobReply(absl::string_view payload, PutBlobReply* m);
absl::Status DecodeEval(absl::string_view payload, EvalRequest* m);
absl::Status DecodeEvalReply(absl::string_view payload, EvalReply* m);
absl::Status DecodePing(absl::string_view payload, PingMessage* m);
absl::Status DecodeError(absl::string_view payload, ErrorMessage* m);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_PROTOCOL_H_
