#include "accel/shim/register_bus.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/shim/component_regs.h"

namespace riskplan::accel {

void RegisterBus::WriteStream(std::span<const uint32_t> words) {
  for (uint32_t word : words) Write32(regs::kStream, word);
}

absl::StatusOr<std::unique_ptr<MappedRegisterBus>> MappedRegisterBus::Open(const std::string& path,
                                                                           uint64_t base,
                                                                           size_t span_bytes) {
  auto bus = std::unique_ptr<MappedRegisterBus>(new MappedRegisterBus());
  bus->name_ = absl::StrFormat("%s@0x%x", path, base);
  bus->fd_ = open(path.c_str(), O_RDWR | O_SYNC | O_CLOEXEC);
  if (bus->fd_ < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("mmio: cannot open ", path, ": ", std::strerror(errno)));
  }
  // mmap takes a page-aligned offset: the page holding `base` is mapped and
  // the registers start `offset` bytes into it.
  const uint64_t page = static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
  const uint64_t aligned = base / page * page;
  const size_t offset = static_cast<size_t>(base - aligned);
  bus->mapping_bytes_ = (offset + span_bytes + page - 1) / page * page;
  void* m = mmap(nullptr, bus->mapping_bytes_, PROT_READ | PROT_WRITE, MAP_SHARED, bus->fd_,
                 static_cast<off_t>(aligned));
  if (m == MAP_FAILED) {
    return absl::FailedPreconditionError(
        absl::StrFormat("mmio: cannot map %d bytes of %s at 0x%x: %s", bus->mapping_bytes_, path,
                        aligned, std::strerror(errno)));
  }
  bus->mapping_ = m;
  bus->registers_ = reinterpret_cast<volatile uint32_t*>(static_cast<char*>(m) + offset);
  bus->span_bytes_ = span_bytes;
  return bus;
}

MappedRegisterBus::~MappedRegisterBus() {
  if (mapping_ != nullptr) munmap(mapping_, mapping_bytes_);
  if (fd_ >= 0) close(fd_);
}

// An access outside the mapped span or not 32-bit aligned is no register of
// the component: it is dropped, and a read of it gives all ones.
uint32_t MappedRegisterBus::Read32(uint32_t offset) {
  if (offset + 4 > span_bytes_ || offset % 4 != 0) return 0xffffffffu;
  return registers_[offset / 4];
}

void MappedRegisterBus::Write32(uint32_t offset, uint32_t value) {
  if (offset + 4 > span_bytes_ || offset % 4 != 0) return;
  registers_[offset / 4] = value;
}

}  // namespace riskplan::accel
