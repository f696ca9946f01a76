#include "accel/prepared_map.h"

#include <sys/mman.h>

#include <cstring>
#include <utility>

namespace riskplan::accel {
namespace {

constexpr size_t kHugePage = size_t{2} << 20;

}  // namespace

HugePageBuffer::HugePageBuffer(size_t bytes) {
  if (bytes == 0) return;
  const size_t size = (bytes + kHugePage - 1) / kHugePage * kHugePage;
  // Over-allocate by one huge page so that the buffer can start on a 2 MiB
  // boundary (the kernel only backs aligned ranges with huge pages).
  void* raw =
      mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) return;
  const uintptr_t start = reinterpret_cast<uintptr_t>(raw);
  const uintptr_t aligned = (start + kHugePage - 1) / kHugePage * kHugePage;
  if (aligned > start) munmap(raw, aligned - start);
  const uintptr_t end = start + size + kHugePage;
  if (end > aligned + size) munmap(reinterpret_cast<void*>(aligned + size), end - aligned - size);
  data_ = reinterpret_cast<void*>(aligned);
  size_ = size;
  // Advice only: without transparent huge pages the buffer works on 4 KiB pages.
  madvise(data_, size_, MADV_HUGEPAGE);
}

HugePageBuffer::HugePageBuffer(HugePageBuffer&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}

HugePageBuffer& HugePageBuffer::operator=(HugePageBuffer&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) munmap(data_, size_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

HugePageBuffer::~HugePageBuffer() {
  if (data_ != nullptr) munmap(data_, size_);
}

size_t PreparedMap::BytesFor(const RiskMap& map) {
  const size_t cells = static_cast<size_t>(map.padded_nx()) * map.padded_ny();
  const size_t bytes = 2 * cells * sizeof(float);
  return (bytes + kHugePage - 1) / kHugePage * kHugePage;
}

std::shared_ptr<const PreparedMap> PreparedMap::Build(const RiskMap& map) {
  const size_t cells = static_cast<size_t>(map.padded_nx()) * map.padded_ny();
  auto prepared = std::shared_ptr<PreparedMap>(new PreparedMap());
  prepared->buffer_ = HugePageBuffer(2 * cells * sizeof(float));
  if (prepared->buffer_.data() == nullptr) return nullptr;
  float* density = static_cast<float*>(prepared->buffer_.data());
  float* shelter = density + cells;
  std::memcpy(density, map.padded_density(), cells * sizeof(float));
  std::memcpy(shelter, map.padded_shelter(), cells * sizeof(float));
  prepared->density_ = density;
  prepared->shelter_ = shelter;
  return prepared;
}

std::shared_ptr<const PreparedMap> PreparedMapCache::Get(
    const std::shared_ptr<const RiskMap>& map) {
  if (map == nullptr || PreparedMap::BytesFor(*map) > budget_bytes()) return nullptr;
  return GetOrBuildOwned<const RiskMap*, PreparedMap>(cache_, map.get(), map,
                                                      [&] { return PreparedMap::Build(*map); });
}

}  // namespace riskplan::accel
