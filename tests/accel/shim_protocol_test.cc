// The shim protocol's frames and messages: round trips, checksums, and the
// refusal of corrupt or malformed input.
#include "accel/shim_protocol.h"

#include <cstring>

#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

TEST(Crc32cTest, MatchesTheStandardCheckValue) {
  EXPECT_EQ(Crc32c("123456789", 9), 0xe3069283u);
  EXPECT_EQ(Crc32c("", 0), 0u);
}

TEST(Sha256Test, MatchesTheStandardTestVector) {
  EXPECT_EQ(HashHex(Sha256("abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(FrameTest, RoundTrips) {
  const std::string frame = EncodeFrame(MessageType::kEval, 42, "payload");
  ASSERT_EQ(frame.size(), kFrameHeaderBytes + 7);
  FrameHeader h;
  ASSERT_TRUE(DecodeHeader(reinterpret_cast<const uint8_t*>(frame.data()), 1024, &h).ok());
  EXPECT_EQ(h.version, kShimProtocolVersion);
  EXPECT_EQ(h.type, MessageType::kEval);
  EXPECT_EQ(h.request_id, 42u);
  EXPECT_EQ(h.payload_bytes, 7u);
  EXPECT_TRUE(CheckPayload(h, absl::string_view(frame).substr(kFrameHeaderBytes)).ok());
  // The magic spells "RPSH".
  EXPECT_EQ(frame.substr(0, 4), "RPSH");
}

TEST(FrameTest, RefusesCorruption) {
  const std::string frame = EncodeFrame(MessageType::kPing, 7, "12345678");
  for (size_t byte = 0; byte < 24; ++byte) {
    std::string bad = frame;
    bad[byte] ^= 0x01;
    FrameHeader h;
    EXPECT_FALSE(DecodeHeader(reinterpret_cast<const uint8_t*>(bad.data()), 1024, &h).ok())
        << "header byte " << byte;
  }
  std::string bad = frame;
  bad[kFrameHeaderBytes + 3] ^= 0x80;
  FrameHeader h;
  ASSERT_TRUE(DecodeHeader(reinterpret_cast<const uint8_t*>(bad.data()), 1024, &h).ok());
  EXPECT_EQ(CheckPayload(h, absl::string_view(bad).substr(kFrameHeaderBytes)).code(),
            absl::StatusCode::kDataLoss);
}

TEST(FrameTest, RefusesOversizedPayloads) {
  const std::string frame = EncodeFrame(MessageType::kPing, 7, std::string(2000, 'x'));
  FrameHeader h;
  EXPECT_EQ(DecodeHeader(reinterpret_cast<const uint8_t*>(frame.data()), 1000, &h).code(),
            absl::StatusCode::kResourceExhausted);
}

TEST(MessagesTest, RoundTrip) {
  HelloReply hello;
  hello.backend = "model";
  hello.device = "d";
  hello.firmware = "f";
  hello.format = NumberFormat::Precise();
  hello.lanes = 8;
  hello.max_sites_per_eval = 100;
  hello.max_payload_bytes = 1 << 20;
  hello.max_kernel_side = 63;
  hello.store_bytes = 1ull << 33;
  hello.clock_hz = 100000000;
  HelloReply h2;
  ASSERT_TRUE(DecodeHelloReply(EncodeHelloReply(hello), &h2).ok());
  EXPECT_EQ(h2.backend, "model");
  EXPECT_EQ(h2.format, NumberFormat::Precise());
  EXPECT_EQ(h2.store_bytes, 1ull << 33);
  EXPECT_EQ(h2.clock_hz, 100000000u);

  EvalRequest eval;
  eval.map = Sha256("map");
  eval.kernels = Sha256("kernels");
  eval.sites = {{20, 71, -3, 1700}, {1, 0, 5, 5}};
  EvalRequest e2;
  ASSERT_TRUE(DecodeEval(EncodeEval(eval), &e2).ok());
  EXPECT_EQ(e2.map, eval.map);
  ASSERT_EQ(e2.sites.size(), 2u);
  EXPECT_EQ(e2.sites[0].heading_bin, 71);
  EXPECT_EQ(e2.sites[0].impact_i, -3);

  EvalReply reply;
  reply.impact_scale = 68;
  reply.shelter_scale = 60;
  reply.device_cycles = 12345;
  reply.impact = {Accumulator{1} << 100, 3};
  reply.shelter = {7, Accumulator{9} << 70};
  EvalReply r2;
  ASSERT_TRUE(DecodeEvalReply(EncodeEvalReply(reply), &r2).ok());
  EXPECT_TRUE(r2.impact[0] == reply.impact[0]);
  EXPECT_TRUE(r2.shelter[1] == reply.shelter[1]);
  EXPECT_EQ(r2.device_cycles, 12345u);

  PutBlobRequest put;
  put.kind = BlobKind::kKernels;
  put.hash = Sha256("x");
  put.total_bytes = 10;
  put.offset = 4;
  put.data = "abc";
  PutBlobRequest p2;
  ASSERT_TRUE(DecodePutBlob(EncodePutBlob(put), &p2).ok());
  EXPECT_EQ(p2.kind, BlobKind::kKernels);
  EXPECT_EQ(p2.data, "abc");
  EXPECT_EQ(p2.offset, 4u);

  ErrorMessage error{ShimErrorCode::kUnknownBlob, "no such blob", Sha256("y")};
  ErrorMessage e3;
  ASSERT_TRUE(DecodeError(EncodeError(error), &e3).ok());
  EXPECT_EQ(e3.code, ShimErrorCode::kUnknownBlob);
  EXPECT_EQ(e3.blob, error.blob);
}

TEST(MessagesTest, RefuseTruncatedAndTrailingBytes) {
  EvalRequest eval;
  eval.sites = {{1, 2, 3, 4}};
  const std::string payload = EncodeEval(eval);
  EvalRequest e;
  EXPECT_FALSE(DecodeEval(payload.substr(0, payload.size() - 1), &e).ok());
  EXPECT_FALSE(DecodeEval(payload + "x", &e).ok());
  HelloRequest h;
  EXPECT_FALSE(DecodeHello("\xff\xff\xff\x7f", &h).ok());  // absurd string length
  PingMessage p;
  EXPECT_FALSE(DecodePing("1234567", &p).ok());
  EvalReply r;
  EXPECT_FALSE(DecodeEvalReply(std::string(31, '\0'), &r).ok());
}

}  // namespace
}  // namespace riskplan::accel
