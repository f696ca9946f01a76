// The known-answer batch an FPGA worker runs when it probes a board: a small
// fixed map and kernel set (deterministic pseudo-random values, windows
// inside, across and beyond the map's edge) whose exact fixed-point sums the
// worker computes itself, for the number format the board announced, with
// the software model of the datapath. A board passes only if every
// accumulator matches bit for bit.
#ifndef RISKPLAN_ACCEL_KNOWN_ANSWER_H_
#define RISKPLAN_ACCEL_KNOWN_ANSWER_H_

#include <vector>

#include "absl/status/status.h"
#include "accel/blobs.h"
#include "accel/shim_client.h"

namespace riskplan::accel {

struct KnownAnswerBatch {
  Blob map;
  Blob kernels;
  std::vector<DeviceSite> sites;
};

// Built once; thread-safe.
const KnownAnswerBatch& GetKnownAnswerBatch();

// Uploads the batch's blobs if the board lacks them, evaluates, and compares
// with the model for client.hello().format. DataLoss naming the first
// mismatch; the client's errors otherwise.
absl::Status RunKnownAnswer(ShimClient& client);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_KNOWN_ANSWER_H_
