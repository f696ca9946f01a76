// The shim's protocol logic without sockets: HELLO, uploads, EVAL, errors.
#include "accel/shim/shim_session.h"

#include "accel/known_answer.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

struct Reply {
  FrameHeader header;
  std::string payload;
  bool close = false;
};

class ShimSessionTest : public ::testing::Test {
 protected:
  ShimSessionTest() : device_(NumberFormat::Board()), store_(NumberFormat::Board(), 63, 1 << 26) {
    context_.device = &device_;
    context_.store = &store_;
    context_.limits.max_sites_per_eval = 1000;
  }

  Reply Send(MessageType type, const std::string& payload, uint16_t version = 1) {
    const std::string frame = EncodeFrame(type, ++id_, payload, version);
    FrameHeader h;
    EXPECT_TRUE(DecodeHeader(reinterpret_cast<const uint8_t*>(frame.data()), 1 << 30, &h).ok());
    Reply r;
    const std::string out =
        session_.Handle(h, absl::string_view(frame).substr(kFrameHeaderBytes), &r.close);
    EXPECT_TRUE(
        DecodeHeader(reinterpret_cast<const uint8_t*>(out.data()), 1 << 30, &r.header).ok());
    r.payload = out.substr(kFrameHeaderBytes);
    EXPECT_TRUE(CheckPayload(r.header, r.payload).ok());
    EXPECT_EQ(r.header.request_id, id_);
    return r;
  }

  void Upload(const Blob& blob, size_t chunk) {
    for (size_t offset = 0; offset < blob.bytes.size(); offset += chunk) {
      PutBlobRequest put{blob.kind, blob.hash, blob.bytes.size(), offset,
                         blob.bytes.substr(offset, chunk)};
      Reply r = Send(MessageType::kPutBlob, EncodePutBlob(put));
      ASSERT_EQ(r.header.type, MessageType::kPutBlobReply);
      PutBlobReply ack;
      ASSERT_TRUE(DecodePutBlobReply(r.payload, &ack).ok());
      EXPECT_EQ(ack.complete, offset + chunk >= blob.bytes.size());
    }
  }

  ModelDevice device_;
  BlobStore store_;
  ShimContext context_;
  ShimSession session_{&context_};
  uint64_t id_ = 0;
};

TEST_F(ShimSessionTest, HelloDescribesTheDevice) {
  Reply r = Send(MessageType::kHello, EncodeHello({"test"}));
  ASSERT_EQ(r.header.type, MessageType::kHelloReply);
  HelloReply hello;
  ASSERT_TRUE(DecodeHelloReply(r.payload, &hello).ok());
  EXPECT_EQ(hello.backend, "model");
  EXPECT_EQ(hello.format, NumberFormat::Board());
  EXPECT_EQ(hello.max_sites_per_eval, 1000u);
}

TEST_F(ShimSessionTest, EvalNamesTheMissingBlobThenAnswersLikeTheModel) {
  const KnownAnswerBatch& batch = GetKnownAnswerBatch();
  EvalRequest eval{batch.map.hash, batch.kernels.hash, batch.sites};
  Reply r = Send(MessageType::kEval, EncodeEval(eval));
  ASSERT_EQ(r.header.type, MessageType::kError);
  ErrorMessage e;
  ASSERT_TRUE(DecodeError(r.payload, &e).ok());
  EXPECT_EQ(e.code, ShimErrorCode::kUnknownBlob);
  EXPECT_EQ(e.blob, batch.map.hash);
  EXPECT_FALSE(r.close);

  Upload(batch.map, 1000);  // in many chunks
  Upload(batch.kernels, 1 << 20);
  r = Send(MessageType::kEval, EncodeEval(eval));
  ASSERT_EQ(r.header.type, MessageType::kEvalReply);
  EvalReply reply;
  ASSERT_TRUE(DecodeEvalReply(r.payload, &reply).ok());
  const QuantizedMap map = *QuantizeMapBlob(batch.map.bytes, NumberFormat::Board(), 8);
  const QuantizedKernelTable kernels =
      *QuantizeKernelsBlob(batch.kernels.bytes, NumberFormat::Board(), 63);
  EXPECT_EQ(reply.impact_scale, 32 + map.density_exponent);
  for (size_t n = 0; n < batch.sites.size(); ++n) {
    const DeviceSite& s = batch.sites[n];
    Accumulator i = 0, sh = 0;
    ModelEwmm(map, kernels.kernel(s.height_bin, s.heading_bin), s.impact_i, s.impact_j, &i, &sh);
    EXPECT_TRUE(i == reply.impact[n] && sh == reply.shelter[n]) << n;
  }
  // What the shim reports when it stops: one EVAL served (the refused one is
  // not counted), its sites, and no device cycles (the model counts none).
  EXPECT_EQ(context_.evals.load(), 1u);
  EXPECT_EQ(context_.sites.load(), batch.sites.size());
  EXPECT_EQ(context_.device_cycles.load(), 0u);
}

TEST_F(ShimSessionTest, RefusesABlobWhoseHashDoesNotMatch) {
  Blob blob = GetKnownAnswerBatch().map;
  blob.hash[0] ^= 1;
  PutBlobRequest put{blob.kind, blob.hash, blob.bytes.size(), 0, blob.bytes};
  Reply r = Send(MessageType::kPutBlob, EncodePutBlob(put));
  ASSERT_EQ(r.header.type, MessageType::kError);
  ErrorMessage e;
  ASSERT_TRUE(DecodeError(r.payload, &e).ok());
  EXPECT_EQ(e.code, ShimErrorCode::kBlobRejected);
}

TEST_F(ShimSessionTest, RefusesOutOfOrderChunksAndTooManySites) {
  const Blob& blob = GetKnownAnswerBatch().map;
  PutBlobRequest put{blob.kind, blob.hash, blob.bytes.size(), 100, blob.bytes.substr(100, 10)};
  EXPECT_EQ(Send(MessageType::kPutBlob, EncodePutBlob(put)).header.type, MessageType::kError);
  EvalRequest eval;
  eval.sites.resize(1001);
  Reply r = Send(MessageType::kEval, EncodeEval(eval));
  ErrorMessage e;
  ASSERT_TRUE(DecodeError(r.payload, &e).ok());
  EXPECT_EQ(e.code, ShimErrorCode::kLimitExceeded);
}

TEST_F(ShimSessionTest, OtherVersionsAndMalformedPayloadsCloseTheConnection) {
  Reply r = Send(MessageType::kHello, EncodeHello({"test"}), 2);
  EXPECT_EQ(r.header.type, MessageType::kError);
  EXPECT_EQ(r.header.version, kShimProtocolVersion);
  EXPECT_TRUE(r.close);
  ErrorMessage e;
  ASSERT_TRUE(DecodeError(r.payload, &e).ok());
  EXPECT_EQ(e.code, ShimErrorCode::kVersionMismatch);

  r = Send(MessageType::kEval, "short");
  EXPECT_TRUE(r.close);
  r = Send(MessageType::kPong, EncodePing({1}));  // not a request
  EXPECT_TRUE(r.close);
}

TEST_F(ShimSessionTest, PingEchoes) {
  Reply r = Send(MessageType::kPing, EncodePing({0xabcdef}));
  ASSERT_EQ(r.header.type, MessageType::kPong);
  PingMessage p;
  ASSERT_TRUE(DecodePing(r.payload, &p).ok());
  EXPECT_EQ(p.nonce, 0xabcdefu);
}

}  // namespace
}  // namespace riskplan::accel
