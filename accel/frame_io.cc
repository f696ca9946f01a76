#include "accel/frame_io.h"

namespace riskplan::accel {

absl::Status ReadFrame(const net::Socket& socket, uint32_t max_payload_bytes, absl::Time deadline,
                       FrameHeader* header, std::string* payload) {
  uint8_t bytes[kFrameHeaderBytes];
  if (absl::Status s = net::RecvAll(socket, bytes, sizeof(bytes), deadline); !s.ok()) return s;
  if (absl::Status s = DecodeHeader(bytes, max_payload_bytes, header); !s.ok()) return s;
  payload->resize(header->payload_bytes);
  if (absl::Status s = net::RecvAll(socket, payload->data(), payload->size(), deadline); !s.ok()) {
    return s;
  }
  return CheckPayload(*header, *payload);
}

}  // namespace riskplan::accel
