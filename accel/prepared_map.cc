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

std::shared_ptr<const PreparedMap> PreparedMapCache::Find(
    const std::shared_ptr<const RiskMap>& map) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (it->key == map.get() && it->owner.lock() == map) {
      entries_.splice(entries_.begin(), entries_, it);
      return it->prepared;
    }
  }
  return nullptr;
}

std::shared_ptr<const PreparedMap> PreparedMapCache::Get(
    const std::shared_ptr<const RiskMap>& map) {
  if (map == nullptr || PreparedMap::BytesFor(*map) > budget_bytes_) return nullptr;
  {
    absl::MutexLock lock(&mu_);
    if (auto hit = Find(map)) return hit;
  }
  absl::MutexLock build_lock(&build_mu_);
  {
    absl::MutexLock lock(&mu_);
    if (auto hit = Find(map)) return hit;
  }
  std::shared_ptr<const PreparedMap> built = PreparedMap::Build(*map);
  if (built == nullptr) return nullptr;
  absl::MutexLock lock(&mu_);
  // Drop the entries of freed maps first, then the least recently used.
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (it->owner.expired()) {
      bytes_ -= it->prepared->MemoryBytes();
      it = entries_.erase(it);
    } else {
      ++it;
    }
  }
  while (!entries_.empty() && bytes_ + built->MemoryBytes() > budget_bytes_) {
    bytes_ -= entries_.back().prepared->MemoryBytes();
    entries_.pop_back();
  }
  entries_.push_front(Entry{map.get(), map, built});
  bytes_ += built->MemoryBytes();
  return built;
}

size_t PreparedMapCache::MemoryBytes() const {
  absl::MutexLock lock(&mu_);
  return bytes_;
}

}  // namespace riskplan::accel
