#include "accel/blobs.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/byte_io.h"

namespace riskplan::accel {
namespace {

constexpr char kMapMagic[8] = {'R', 'P', 'M', 'A', 'P', '0', '0', '1'};
constexpr char kKernelsMagic[8] = {'R', 'P', 'K', 'R', 'N', '0', '0', '1'};

absl::Status BlobError(absl::string_view what) {
  return absl::InvalidArgumentError(absl::StrCat("blob: ", what));
}

}  // namespace

KernelSet KernelSetOf(const ImpactTable& table) {
  KernelSet set;
  set.height_bins = table.height_bins();
  set.heading_bins = table.heading_bins();
  for (int b = 1; b <= set.height_bins; ++b) {
    set.half_width.push_back(table.bin(b).half_width);
    for (int k = 0; k < set.heading_bins; ++k) {
      const ImpactKernel& kernel = table.kernel(b, k);
      const int side = kernel.Side();
      std::vector<double> w(static_cast<size_t>(side) * side);
      for (int v = 0; v < side; ++v) {
        std::memcpy(&w[static_cast<size_t>(v) * side], kernel.weights + v * kernel.Stride(),
                    side * sizeof(double));
      }
      set.weights.push_back(std::move(w));
    }
  }
  return set;
}

std::string EncodeMapBlob(int nx, int ny, const float* density, const float* shelter) {
  const size_t cells = static_cast<size_t>(nx) * ny;
  std::string out;
  out.reserve(16 + 8 * cells);
  ByteWriter w(&out);
  w.PutBytes(kMapMagic, sizeof(kMapMagic));
  w.Put<uint32_t>(static_cast<uint32_t>(nx));
  w.Put<uint32_t>(static_cast<uint32_t>(ny));
  w.PutBytes(density, cells * sizeof(float));
  w.PutBytes(shelter, cells * sizeof(float));
  return out;
}

std::string EncodeMapBlob(const RiskMap& map) {
  return EncodeMapBlob(map.nx(), map.ny(), map.layers().density.data(),
                       map.layers().shelter.data());
}

std::string EncodeKernelsBlob(const KernelSet& kernels) {
  std::string out;
  ByteWriter w(&out);
  w.PutBytes(kKernelsMagic, sizeof(kKernelsMagic));
  w.Put<uint32_t>(static_cast<uint32_t>(kernels.height_bins));
  w.Put<uint32_t>(static_cast<uint32_t>(kernels.heading_bins));
  for (int b = 1; b <= kernels.height_bins; ++b) {
    w.Put<uint32_t>(static_cast<uint32_t>(kernels.half_width[b - 1]));
    for (int k = 0; k < kernels.heading_bins; ++k) {
      const std::vector<double>& weights =
          kernels.weights[static_cast<size_t>(b - 1) * kernels.heading_bins + k];
      w.PutBytes(weights.data(), weights.size() * sizeof(double));
    }
  }
  return out;
}

size_t QuantizedKernelTable::MemoryBytes() const {
  size_t bytes = kernels.size() * sizeof(QuantizedKernel);
  for (const QuantizedKernel& k : kernels) bytes += k.weights.size() * sizeof(uint64_t);
  return bytes;
}

absl::StatusOr<QuantizedMap> QuantizeMapBlob(absl::string_view blob, const NumberFormat& format,
                                             int pad) {
  ByteReader r(blob);
  char magic[8];
  uint32_t nx = 0, ny = 0;
  if (!r.GetBytes(magic, sizeof(magic)) || std::memcmp(magic, kMapMagic, sizeof(magic)) != 0) {
    return BlobError("not a map blob (magic)");
  }
  if (!r.Get(&nx) || !r.Get(&ny) || nx == 0 || ny == 0 || nx > uint32_t{kMaxMapSide} ||
      ny > uint32_t{kMaxMapSide} || uint64_t{nx} * ny > uint64_t(kMaxMapCells)) {
    return BlobError("map blob: bad size");
  }
  const size_t cells = size_t{nx} * ny;
  if (r.remaining() != 8 * cells) {
    return BlobError(
        absl::StrFormat("map blob: %zu bytes of layers, expected %zu", r.remaining(), 8 * cells));
  }
  std::vector<float> density(cells), shelter(cells);
  r.GetBytes(density.data(), cells * sizeof(float));
  r.GetBytes(shelter.data(), cells * sizeof(float));
  for (size_t c = 0; c < cells; ++c) {
    if (!(std::isfinite(density[c]) && density[c] >= 0.0f)) {
      return BlobError(absl::StrFormat("map blob: density of cell %zu is %g", c, density[c]));
    }
    if (!(shelter[c] >= 0.0f && shelter[c] <= 10.0f)) {
      return BlobError(absl::StrFormat("map blob: shelter of cell %zu is %g", c, shelter[c]));
    }
  }
  return QuantizeMap(static_cast<int>(nx), static_cast<int>(ny), density.data(), shelter.data(),
                     format, pad);
}

absl::StatusOr<QuantizedKernelTable> QuantizeKernelsBlob(absl::string_view blob,
                                                         const NumberFormat& format, int max_side) {
  ByteReader r(blob);
  char magic[8];
  uint32_t bins = 0, headings = 0;
  if (!r.GetBytes(magic, sizeof(magic)) || std::memcmp(magic, kKernelsMagic, sizeof(magic)) != 0) {
    return BlobError("not a kernels blob (magic)");
  }
  if (!r.Get(&bins) || !r.Get(&headings) || bins == 0 || headings == 0 || bins > 4096 ||
      headings > 4096) {
    return BlobError("kernels blob: bad bin counts");
  }
  QuantizedKernelTable table;
  table.height_bins = static_cast<int>(bins);
  table.heading_bins = static_cast<int>(headings);
  table.kernels.reserve(size_t{bins} * headings);
  for (uint32_t b = 1; b <= bins; ++b) {
    uint32_t hw = 0;
    if (!r.Get(&hw) || 2 * uint64_t{hw} + 1 > uint64_t(max_side)) {
      return BlobError(
          absl::StrFormat("kernels blob: height bin %u: half width missing or wider "
                          "than the device's largest side %d",
                          b, max_side));
    }
    const int side = 2 * static_cast<int>(hw) + 1;
    for (uint32_t k = 0; k < headings; ++k) {
      QuantizedKernel kernel;
      kernel.half_width = static_cast<int>(hw);
      kernel.weights.resize(static_cast<size_t>(side) * side);
      for (uint64_t& q : kernel.weights) {
        double w = 0.0;
        if (!r.Get(&w)) return BlobError("kernels blob: truncated");
        if (!(w >= 0.0 && w <= 1.0)) {
          return BlobError(
              absl::StrFormat("kernels blob: weight %g of kernel (%u, %u) not in [0, 1]", w, b, k));
        }
        q = QuantizeWeight(w, format.weight_frac_bits);
      }
      table.kernels.push_back(std::move(kernel));
    }
  }
  if (!r.done()) return BlobError("kernels blob: trailing bytes");
  return table;
}

bool BlobCache::RefusedLocked(const std::shared_ptr<const void>& owner) const {
  for (const std::weak_ptr<const void>& refused : refused_) {
    if (refused.lock() == owner) return true;
  }
  return false;
}

std::shared_ptr<const Blob> BlobCache::Get(const std::shared_ptr<const void>& owner,
                                           absl::FunctionRef<Blob()> build) {
  {
    absl::MutexLock lock(&refused_mu_);
    if (RefusedLocked(owner)) return nullptr;
  }
  // The build cannot fail, so neither can this.
  std::shared_ptr<const Blob> blob = *cache_.GetOrBuild(
      owner.get(),
      [&]() -> absl::StatusOr<BoundedCache<const void*, Blob>::Built> {
        auto built = std::make_shared<const Blob>(build());
        return BoundedCache<const void*, Blob>::Built{built, built->bytes.size()};
      },
      owner);
  if (blob->bytes.size() <= budget_bytes()) return blob;
  // Larger than the whole budget: the cache did not keep it. Remembered, so
  // that later calls return null at once instead of building it again.
  absl::MutexLock lock(&refused_mu_);
  refused_.remove_if([](const std::weak_ptr<const void>& refused) { return refused.expired(); });
  if (!RefusedLocked(owner)) refused_.push_back(owner);  // two callers raced
  return nullptr;
}

std::shared_ptr<const Blob> BlobCache::MapBlob(const std::shared_ptr<const RiskMap>& map) {
  return Get(map, [&] {
    Blob blob;
    blob.kind = BlobKind::kMap;
    blob.bytes = EncodeMapBlob(*map);
    blob.hash = Sha256(blob.bytes);
    for (float d : map->layers().density) blob.max_density = std::max<double>(blob.max_density, d);
    return blob;
  });
}

std::shared_ptr<const Blob> BlobCache::KernelsBlob(
    const std::shared_ptr<const ImpactTable>& table) {
  return Get(table, [&] {
    Blob blob;
    blob.kind = BlobKind::kKernels;
    blob.bytes = EncodeKernelsBlob(KernelSetOf(*table));
    blob.hash = Sha256(blob.bytes);
    return blob;
  });
}

}  // namespace riskplan::accel
