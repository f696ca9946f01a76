#include "accel/rtl/verilated_component.h"

#include <span>
#include <utility>

#include "Vrp_ewmm_l16_precise.h"
#include "Vrp_ewmm_l8_board.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "accel/shim/component_regs.h"
#include "verilated.h"

namespace riskplan::accel {
namespace {

// One stream beat: {shelter, density}, density in the low half.
inline void SetBeat(QData& port, const uint32_t* words) {
  port = uint64_t{words[1]} << 32 | words[0];
}
inline void SetBeat(VlWide<4>& port, const uint32_t* words) {
  for (int w = 0; w < 4; ++w) port[w] = words[w];
}

template <class Top>
class VerilatedBus final : public SimulatedComponentBus {
 public:
  explicit VerilatedBus(const RtlConfig& config)
      : config_(config), context_(std::make_unique<VerilatedContext>()) {
    top_ = std::make_unique<Top>(context_.get(), "rp_ewmm");
    top_->reset = 1;
    Clock();
    Clock();
    top_->reset = 0;
    top_->eval();
  }
  ~VerilatedBus() override { top_->final(); }

  uint32_t Read32(uint32_t offset) override {
    if (offset % 4 != 0 || offset >= kSpan) return 0xffffffffu;
    top_->avs_address = offset / 4;
    top_->avs_read = 1;
    Clock();
    top_->avs_read = 0;
    return top_->avs_readdata;
  }

  void Write32(uint32_t offset, uint32_t value) override {
    if (offset % 4 != 0 || offset >= kSpan) return;
    top_->avs_address = offset / 4;
    top_->avs_writedata = value;
    top_->avs_write = 1;
    Clock();
    top_->avs_write = 0;
  }

  // Whole cells go through the Avalon-ST sink, one per clock while it is
  // ready; what it does not take (a partial cell, or cells with no job
  // running) goes through the STREAM register, which reports a stream without
  // a job (error 2) as the board would.
  void WriteStream(std::span<const uint32_t> words) override {
    const size_t per_cell = config_.format.cell_bits <= 32 ? 2 : 4;
    size_t n = 0;
    int stalls = 0;
    while (n + per_cell <= words.size()) {
      SetBeat(top_->asi_data, &words[n]);
      top_->asi_valid = 1;
      top_->clk = 0;
      top_->eval();
      const bool taken = top_->asi_ready;
      top_->clk = 1;
      top_->eval();
      ++cycles_;
      if (taken) {
        n += per_cell;
        stalls = 0;
      } else if (++stalls > kMaxStalls) {
        break;
      }
    }
    top_->asi_valid = 0;
    for (; n < words.size(); ++n) Write32(regs::kStream, words[n]);
  }

  std::string Name() const override { return absl::StrCat("verilator:", config_.name); }
  uint64_t cycles() const override { return cycles_; }
  const RtlConfig& config() const override { return config_; }

 private:
  // The CSR slave decodes 10 word-address bits.
  static constexpr uint32_t kSpan = 4096;
  // The sink is ready whenever a job is taking cells; a few clocks of "not
  // ready" mean there is no job.
  static constexpr int kMaxStalls = 16;

  void Clock() {
    top_->clk = 0;
    top_->eval();
    top_->clk = 1;
    top_->eval();
    ++cycles_;
  }

  const RtlConfig config_;
  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Top> top_;
  uint64_t cycles_ = 0;
};

}  // namespace

const std::vector<RtlConfig>& VerilatedConfigs() {
  // Must match the parameters given to verilate() in accel/rtl/CMakeLists.txt
  // (tests/rtl/rtl_component_test.cc reads them back from CAPS and LIMITS).
  static const std::vector<RtlConfig>* const configs = new std::vector<RtlConfig>{
      {"l8-board", 8, NumberFormat::Board(), 4, 63, 100'000'000,
       "8 lanes, w32m32a80, 4 kernel slots of 63 x 63: the DE10-Nano build"},
      {"l16-precise", 16, NumberFormat::Precise(), 8, 63, 100'000'000,
       "16 lanes, w48m48a128, 8 kernel slots of 63 x 63"},
  };
  return *configs;
}

absl::StatusOr<std::unique_ptr<SimulatedComponentBus>> OpenVerilatedComponent(
    absl::string_view config) {
  const std::vector<RtlConfig>& configs = VerilatedConfigs();
  if (config == configs[0].name) {
    return std::unique_ptr<SimulatedComponentBus>(new VerilatedBus<Vrp_ewmm_l8_board>(configs[0]));
  }
  if (config == configs[1].name) {
    return std::unique_ptr<SimulatedComponentBus>(
        new VerilatedBus<Vrp_ewmm_l16_precise>(configs[1]));
  }
  std::vector<std::string> names;
  for (const RtlConfig& c : configs) names.push_back(c.name);
  return absl::NotFoundError(absl::StrCat("no verilated RTL configuration '", config,
                                          "'; this build has: ", absl::StrJoin(names, ", ")));
}

}  // namespace riskplan::accel
