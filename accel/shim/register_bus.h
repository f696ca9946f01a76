// RegisterBus: 32-bit register access to the streaming EWMM component.
//
// MappedRegisterBus maps the component's span from a device file: /dev/mem
// (at the component's physical base, e.g. the lightweight HPS-to-FPGA bridge
// 0xFF200000 plus its offset in Platform Designer) or /dev/uioN (offset 0),
// and accesses it with volatile 32-bit loads and stores. Against a regular
// file it maps the file, which is how tests exercise it without a board.
//
// ComponentModel (component_model.h) is an in-memory bus that behaves like
// the component; the RTL under Verilator (accel/rtl/verilated_component.h)
// is a third.
//
// Not thread-safe: the shim serialises device access.
#ifndef RISKPLAN_ACCEL_SHIM_REGISTER_BUS_H_
#define RISKPLAN_ACCEL_SHIM_REGISTER_BUS_H_

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "absl/status/statusor.h"

namespace riskplan::accel {

class RegisterBus {
 public:
  virtual ~RegisterBus() = default;
  virtual uint32_t Read32(uint32_t offset) = 0;
  virtual void Write32(uint32_t offset, uint32_t value) = 0;
  // Writes `words` to the STREAM register, in order. A bus with a faster way
  // to the component's stream (the RTL's Avalon-ST sink under Verilator; a
  // DMA on a board) overrides it.
  virtual void WriteStream(std::span<const uint32_t> words);
  // A human-readable name ("/dev/mem@0xff200000", "model").
  virtual std::string Name() const = 0;
};

class MappedRegisterBus final : public RegisterBus {
 public:
  // Maps `span_bytes` at byte `base` of `path` (base rounded down to a page,
  // the remainder kept as an offset). Errors name the path and errno.
  static absl::StatusOr<std::unique_ptr<MappedRegisterBus>> Open(const std::string& path,
                                                                 uint64_t base, size_t span_bytes);
  ~MappedRegisterBus() override;

  uint32_t Read32(uint32_t offset) override;
  void Write32(uint32_t offset, uint32_t value) override;
  std::string Name() const override { return name_; }

 private:
  MappedRegisterBus() = default;

  int fd_ = -1;
  void* mapping_ = nullptr;
  size_t mapping_bytes_ = 0;
  volatile uint32_t* registers_ = nullptr;
  size_t span_bytes_ = 0;
  std::string name_;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_REGISTER_BUS_H_
