// One shim-protocol frame read off a socket of net/net.h: the piece of the
// shim link that knows both the protocol and the socket. It lives here, not
// in net/, because net/ knows nothing of the shim protocol (the server uses
// net/ too).
#ifndef RISKPLAN_ACCEL_FRAME_IO_H_
#define RISKPLAN_ACCEL_FRAME_IO_H_

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "accel/shim_protocol.h"
#include "net/net.h"

namespace riskplan::accel {

// Reads one frame: header checked (DecodeHeader), payload read and checked
// against its CRC. The version is left to the caller.
absl::Status ReadFrame(const net::Socket& socket, uint32_t max_payload_bytes, absl::Time deadline,
                       FrameHeader* header, std::string* payload);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_FRAME_IO_H_
