#include "accel/known_answer.h"

#include "absl/strings/str_format.h"
#include "core/base/random.h"

namespace riskplan::accel {
namespace {

KnownAnswerBatch Build() {
  constexpr int kNx = 40;
  constexpr int kNy = 28;
  Rng rng(20240605);
  std::vector<float> density(kNx * kNy), shelter(kNx * kNy);
  for (int c = 0; c < kNx * kNy; ++c) {
    // Mostly small densities with a few dense cells, and shelter over its range.
    density[c] =
        static_cast<float>(rng.Uniform() < 0.1 ? 0.05 * rng.Uniform() : 1e-3 * rng.Uniform());
    shelter[c] = static_cast<float>(10.0 * rng.Uniform());
  }
  KnownAnswerBatch batch;
  batch.map.kind = BlobKind::kMap;
  batch.map.bytes = EncodeMapBlob(kNx, kNy, density.data(), shelter.data());
  batch.map.hash = Sha256(batch.map.bytes);

  KernelSet kernels;
  kernels.height_bins = 3;
  kernels.heading_bins = 4;
  kernels.half_width = {1, 3, 6};
  for (int b = 1; b <= kernels.height_bins; ++b) {
    const int side = 2 * kernels.half_width[b - 1] + 1;
    for (int k = 0; k < kernels.heading_bins; ++k) {
      std::vector<double> w(side * side);
      double sum = 0.0;
      for (double& x : w) sum += (x = rng.Uniform());
      for (double& x : w) x /= sum;
      kernels.weights.push_back(std::move(w));
    }
  }
  batch.kernels.kind = BlobKind::kKernels;
  batch.kernels.bytes = EncodeKernelsBlob(kernels);
  batch.kernels.hash = Sha256(batch.kernels.bytes);

  // Inside, on every edge and corner, and entirely outside the map.
  const int cells[][2] = {{20, 14}, {0, 0},   {39, 27}, {-3, 5}, {45, 10}, {10, -4},
                          {12, 31}, {-8, -8}, {50, 40}, {1, 26}, {38, 1},  {19, 0}};
  for (const auto& c : cells) {
    for (int b = 1; b <= kernels.height_bins; ++b) {
      batch.sites.push_back(
          DeviceSite{static_cast<uint16_t>(b), static_cast<uint16_t>((c[0] + b) & 3), c[0], c[1]});
    }
  }
  return batch;
}

}  // namespace

const KnownAnswerBatch& GetKnownAnswerBatch() {
  static const KnownAnswerBatch* batch = new KnownAnswerBatch(Build());
  return *batch;
}

absl::Status RunKnownAnswer(ShimClient& client) {
  const KnownAnswerBatch& batch = GetKnownAnswerBatch();
  const NumberFormat& format = client.hello().format;
  absl::StatusOr<QuantizedMap> map = QuantizeMapBlob(batch.map.bytes, format, 8);
  absl::StatusOr<QuantizedKernelTable> kernels =
      QuantizeKernelsBlob(batch.kernels.bytes, format, 63);
  if (!map.ok()) return map.status();
  if (!kernels.ok()) return kernels.status();
  absl::StatusOr<EvalReply> reply = client.Eval(batch.map.hash, batch.kernels.hash, batch.sites);
  // At most two uploads, the map's and the kernels': a board that asks for
  // more fails the check.
  for (int upload = 0; upload < 2 && !reply.ok() && absl::IsNotFound(reply.status()); ++upload) {
    const Blob& missing = client.missing_blob() == batch.map.hash ? batch.map : batch.kernels;
    if (absl::Status s = client.PutBlob(missing.kind, missing.hash, missing.bytes); !s.ok()) {
      return s;
    }
    reply = client.Eval(batch.map.hash, batch.kernels.hash, batch.sites);
  }
  if (!reply.ok()) return reply.status();
  if (reply->impact_scale != format.weight_frac_bits + map->density_exponent ||
      reply->shelter_scale != format.weight_frac_bits + map->shelter_exponent) {
    return absl::DataLossError(absl::StrFormat("known-answer batch: scales %d/%d, expected %d/%d",
                                               reply->impact_scale, reply->shelter_scale,
                                               format.weight_frac_bits + map->density_exponent,
                                               format.weight_frac_bits + map->shelter_exponent));
  }
  for (size_t n = 0; n < batch.sites.size(); ++n) {
    const DeviceSite& s = batch.sites[n];
    Accumulator impact = 0, shelter = 0;
    ModelEwmm(*map, kernels->kernel(s.height_bin, s.heading_bin), s.impact_i, s.impact_j, &impact,
              &shelter);
    if (impact != reply->impact[n] || shelter != reply->shelter[n]) {
      return absl::DataLossError(absl::StrFormat(
          "known-answer batch: site %d (bin %d, heading %d, cell %d, %d) differs from the model", n,
          s.height_bin, s.heading_bin, s.impact_i, s.impact_j));
    }
  }
  return absl::OkStatus();
}

}  // namespace riskplan::accel
