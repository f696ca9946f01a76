#include "accel/kernel_weights.h"

#include <cstring>

namespace riskplan::accel {
namespace {

constexpr size_t kHugePage = size_t{2} << 20;

size_t ElementBytes(WeightFormat format) {
  return format == WeightFormat::kDouble ? sizeof(double) : sizeof(float);
}

// Elements of every kernel of the table, in (b, k) order. Every kernel's size
// is a whole number of 64-byte rows, so each starts on a 64-byte boundary.
size_t TotalElements(const ImpactTable& table, WeightFormat format, std::vector<size_t>* offsets) {
  size_t total = 0;
  for (int b = 1; b <= table.height_bins(); ++b) {
    for (int k = 0; k < table.heading_bins(); ++k) {
      const int side = table.kernel(b, k).Side();
      if (offsets != nullptr) offsets->push_back(total);
      total += static_cast<size_t>(side) * KernelWeights::StrideFor(side, format);
    }
  }
  return total;
}

}  // namespace

int KernelWeights::StrideFor(int side, WeightFormat format) {
  const int per_line = format == WeightFormat::kDouble ? 8 : 16;
  return (side + per_line - 1) / per_line * per_line;
}

size_t KernelWeights::BytesFor(const ImpactTable& table, WeightFormat format) {
  const size_t bytes = TotalElements(table, format, nullptr) * ElementBytes(format);
  return (bytes + kHugePage - 1) / kHugePage * kHugePage;
}

std::shared_ptr<const KernelWeights> KernelWeights::Build(const ImpactTable& table,
                                                          WeightFormat format) {
  auto weights = std::shared_ptr<KernelWeights>(new KernelWeights());
  weights->format_ = format;
  weights->heading_bins_ = table.heading_bins();
  const size_t total = TotalElements(table, format, &weights->offsets_);
  weights->buffer_ = HugePageBuffer(total * ElementBytes(format));
  if (weights->buffer_.data() == nullptr) return nullptr;
  for (int b = 1; b <= table.height_bins(); ++b) {
    for (int k = 0; k < table.heading_bins(); ++k) {
      const ImpactKernel& kernel = table.kernel(b, k);
      const int side = kernel.Side();
      const size_t offset = weights->offsets_[weights->Index(b, k)];
      if (format == WeightFormat::kDouble) {
        // Same stride as the table: a plain copy (the buffer is zero-filled).
        std::memcpy(static_cast<double*>(weights->buffer_.data()) + offset, kernel.weights,
                    static_cast<size_t>(side) * kernel.Stride() * sizeof(double));
        continue;
      }
      float* out = static_cast<float*>(weights->buffer_.data()) + offset;
      const int stride = StrideFor(side, format);
      for (int v = 0; v < side; ++v) {
        for (int u = 0; u < side; ++u) {
          out[v * stride + u] = static_cast<float>(kernel.weights[v * kernel.Stride() + u]);
        }
      }
    }
  }
  return weights;
}

std::shared_ptr<const KernelWeights> KernelWeightsCache::Get(
    const std::shared_ptr<const ImpactTable>& table, WeightFormat format) {
  if (table == nullptr || KernelWeights::BytesFor(*table, format) > budget_bytes()) return nullptr;
  return GetOrBuildOwned<Key, KernelWeights>(cache_, Key{table.get(), format}, table,
                                             [&] { return KernelWeights::Build(*table, format); });
}

}  // namespace riskplan::accel
