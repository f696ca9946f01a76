#include "accel/shim/mmio_device.h"

#include <algorithm>
#include <numeric>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/shim/component_regs.h"
#include "core/base/check.h"

namespace riskplan::accel {

absl::StatusOr<std::unique_ptr<MmioDevice>> MmioDevice::Open(std::unique_ptr<RegisterBus> bus,
                                                             const MmioOptions& options) {
  const uint32_t id = bus->Read32(regs::kId);
  if (id != regs::kIdValue) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "mmio: %s shows ID 0x%08x, not the EWMM component's 0x%08x (wrong base address or "
        "bitstream?)",
        bus->Name(), id, regs::kIdValue));
  }
  const uint32_t version = bus->Read32(regs::kVersion);
  if (version >> 16 != regs::kVersionValue >> 16) {
    return absl::FailedPreconditionError(
        absl::StrFormat("mmio: component version %d.%d, this backend drives %d.x", version >> 16,
                        version & 0xffff, regs::kVersionValue >> 16));
  }
  auto device = std::unique_ptr<MmioDevice>(new MmioDevice(std::move(bus), options));
  RegisterBus& b = *device->bus_;
  b.Write32(regs::kCtrl, regs::kCtrlReset);
  const uint32_t caps = b.Read32(regs::kCaps);
  const uint32_t limits = b.Read32(regs::kLimits);
  DeviceInfo& info = device->info_;
  info.backend = options.backend;
  info.device = b.Name();
  info.firmware = absl::StrFormat("EWMM component %d.%d", version >> 16, version & 0xffff);
  info.format = NumberFormat{static_cast<int>((caps >> 8) & 0xff),
                             static_cast<int>((caps >> 16) & 0xff), static_cast<int>(caps >> 24)};
  info.lanes = caps & 0xff;
  if (options.max_lanes != 0 && options.max_lanes < info.lanes) info.lanes = options.max_lanes;
  info.max_kernel_side = limits & 0xffff;
  info.clock_hz = b.Read32(regs::kClockHz);
  device->slots_count_ = limits >> 16;
  if (absl::Status s = info.format.Validate(); !s.ok()) {
    return absl::FailedPreconditionError(absl::StrCat("mmio: component reports ", s.message()));
  }
  if (info.lanes == 0 || info.lanes > regs::kMaxLanes || device->slots_count_ == 0 ||
      info.max_kernel_side == 0) {
    return absl::FailedPreconditionError("mmio: component reports no lanes, slots or kernel side");
  }
  device->slots_.resize(device->slots_count_);
  return device;
}

uint32_t MmioDevice::SlotFor(const QuantizedKernelTable& kernels, int b, int k,
                             const std::vector<uint32_t>& busy) {
  ++clock_;
  for (uint32_t s = 0; s < slots_count_; ++s) {
    if (slots_[s].table_id == kernels.id && slots_[s].height_bin == b &&
        slots_[s].heading_bin == k) {
      slots_[s].last_use = clock_;
      return s;
    }
  }
  // Not loaded: the least recently used slot that no lane of this job uses
  // is replaced (kernels stay in their slots between jobs).
  uint32_t victim = slots_count_;
  for (uint32_t s = 0; s < slots_count_; ++s) {
    if (std::find(busy.begin(), busy.end(), s) != busy.end()) continue;
    if (victim == slots_count_ || slots_[s].last_use < slots_[victim].last_use) victim = s;
  }
  const QuantizedKernel& kernel = kernels.kernel(b, k);
  bus_->Write32(regs::kWaddr, victim << 16);
  for (uint64_t w : kernel.weights) {
    bus_->Write32(regs::kWdataLo, static_cast<uint32_t>(w));
    bus_->Write32(regs::kWdataHi, static_cast<uint32_t>(w >> 32));
  }
  slots_[victim] = Slot{kernels.id, b, k, clock_};
  ++kernel_uploads_;
  return victim;
}

void MmioDevice::StreamValue(uint64_t value) {
  stream_.push_back(static_cast<uint32_t>(value));
  if (info_.format.cell_bits > 32) stream_.push_back(static_cast<uint32_t>(value >> 32));
}

absl::Status MmioDevice::RunJob(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                                std::span<const DeviceSite> sites, std::span<const uint32_t> job,
                                std::span<Accumulator> impact, std::span<Accumulator> shelter,
                                uint64_t* cycles) {
  // The cut: the bounding box of the lanes' windows, in map cells.
  int i0 = 0, j0 = 0, i1 = 0, j1 = 0;
  for (size_t l = 0; l < job.size(); ++l) {
    const DeviceSite& s = sites[job[l]];
    const int hw = kernels.kernel(s.height_bin, s.heading_bin).half_width;
    if (l == 0 || s.impact_i - hw < i0) i0 = s.impact_i - hw;
    if (l == 0 || s.impact_j - hw < j0) j0 = s.impact_j - hw;
    if (l == 0 || s.impact_i + hw + 1 > i1) i1 = s.impact_i + hw + 1;
    if (l == 0 || s.impact_j + hw + 1 > j1) j1 = s.impact_j + hw + 1;
  }
  std::vector<uint32_t> busy;
  for (size_t l = 0; l < job.size(); ++l) {
    const DeviceSite& s = sites[job[l]];
    const uint32_t slot = SlotFor(kernels, s.height_bin, s.heading_bin, busy);
    busy.push_back(slot);
    const int hw = kernels.kernel(s.height_bin, s.heading_bin).half_width;
    bus_->Write32(regs::LaneReg(l, regs::kLaneSlot), slot);
    bus_->Write32(regs::LaneReg(l, regs::kLaneSide), static_cast<uint32_t>(2 * hw + 1));
    bus_->Write32(regs::LaneReg(l, regs::kLaneCol), static_cast<uint32_t>(s.impact_i - hw - i0));
    bus_->Write32(regs::LaneReg(l, regs::kLaneRow), static_cast<uint32_t>(s.impact_j - hw - j0));
  }
  bus_->Write32(regs::kCutCols, static_cast<uint32_t>(i1 - i0));
  bus_->Write32(regs::kCutRows, static_cast<uint32_t>(j1 - j0));
  bus_->Write32(regs::kLaneMask, job.size() >= 32 ? 0xffffffffu : (uint32_t{1} << job.size()) - 1);
  bus_->Write32(regs::kCtrl, regs::kCtrlStart);
  // STATUS is read once before streaming, to see a refused job before its
  // cells are sent (the RTL spends one clock on it, docs/rtl.md, "Cycles").
  uint32_t status = bus_->Read32(regs::kStatus);
  if (status & regs::kStatusError) {
    return absl::InternalError(
        absl::StrFormat("mmio: job refused, error code %d", (status >> 8) & 0xff));
  }
  stream_.clear();
  for (int j = j0; j < j1; ++j) {
    for (int i = i0; i < i1; ++i) {
      StreamValue(map.DensityAt(i, j));
      StreamValue(map.ShelterAt(i, j));
    }
  }
  bus_->WriteStream(stream_);
  const absl::Time deadline = absl::Now() + options_.job_timeout;
  while (!((status = bus_->Read32(regs::kStatus)) & regs::kStatusDone)) {
    if (absl::Now() > deadline) {
      // The component may still be running the job: RESET aborts it.
      bus_->Write32(regs::kCtrl, regs::kCtrlReset);
      return absl::DeadlineExceededError("mmio: the component did not finish a job in time");
    }
  }
  if (status & regs::kStatusError) {
    bus_->Write32(regs::kCtrl, regs::kCtrlReset);
    return absl::InternalError(
        absl::StrFormat("mmio: job failed, error code %d", (status >> 8) & 0xff));
  }
  for (size_t l = 0; l < job.size(); ++l) {
    uint32_t words[4];
    for (int w = 0; w < 4; ++w)
      words[w] = bus_->Read32(regs::LaneReg(l, regs::kLaneImpact + 4 * w));
    impact[job[l]] = AccumulatorFromWords(words);
    for (int w = 0; w < 4; ++w) {
      words[w] = bus_->Read32(regs::LaneReg(l, regs::kLaneShelter + 4 * w));
    }
    shelter[job[l]] = AccumulatorFromWords(words);
  }
  *cycles += uint64_t{bus_->Read32(regs::kCyclesHi)} << 32 | bus_->Read32(regs::kCyclesLo);
  ++jobs_;
  return absl::OkStatus();
}

absl::Status MmioDevice::Evaluate(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                                  std::span<const DeviceSite> sites, std::span<Accumulator> impact,
                                  std::span<Accumulator> shelter, uint64_t* cycles) {
  RISKPLAN_DCHECK(impact.size() == sites.size() && shelter.size() == sites.size());
  *cycles = 0;
  // Sites are taken in the order they came: a planner's and EvaluateRisk's
  // batches list the samples of a trajectory one after the other, so
  // neighbours share a cut. (Sorting by impact cell interleaves the samples of
  // different trajectories and measured worse.)
  std::vector<uint32_t> order(sites.size());
  std::iota(order.begin(), order.end(), 0);
  const auto window = [&](uint32_t n, int* i0, int* j0, int* i1, int* j1) {
    const int hw = kernels.kernel(sites[n].height_bin, sites[n].heading_bin).half_width;
    *i0 = sites[n].impact_i - hw;
    *j0 = sites[n].impact_j - hw;
    *i1 = sites[n].impact_i + hw + 1;
    *j1 = sites[n].impact_j + hw + 1;
  };
  size_t first = 0;
  while (first < order.size()) {
    int i0, j0, i1, j1;
    window(order[first], &i0, &j0, &i1, &j1);
    std::vector<std::pair<int, int>> distinct_kernels = {
        {sites[order[first]].height_bin, sites[order[first]].heading_bin}};
    size_t last = first + 1;
    while (last < order.size() && last - first < info_.lanes) {
      int a0, b0, a1, b1;
      window(order[last], &a0, &b0, &a1, &b1);
      const int64_t cols = std::max(i1, a1) - std::min(i0, a0);
      const int64_t rows = std::max(j1, b1) - std::min(j0, b0);
      const std::pair<int, int> kernel = {sites[order[last]].height_bin,
                                          sites[order[last]].heading_bin};
      const bool new_kernel = std::find(distinct_kernels.begin(), distinct_kernels.end(), kernel) ==
                              distinct_kernels.end();
      if (cols * rows > options_.max_cut_cells ||
          (new_kernel && distinct_kernels.size() == slots_count_)) {
        break;
      }
      if (new_kernel) distinct_kernels.push_back(kernel);
      i0 = std::min(i0, a0);
      j0 = std::min(j0, b0);
      i1 = std::max(i1, a1);
      j1 = std::max(j1, b1);
      ++last;
    }
    if (absl::Status s = RunJob(map, kernels, sites,
                                std::span<const uint32_t>(order).subspan(first, last - first),
                                impact, shelter, cycles);
        !s.ok()) {
      return s;
    }
    first = last;
  }
  return absl::OkStatus();
}

}  // namespace riskplan::accel
