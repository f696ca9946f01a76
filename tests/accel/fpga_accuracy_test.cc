// Results through the real riskplan-fpga-shim: with the model backend, and
// with the mmio backend on the component model, every result equals what the
// fixed-point datapath must give, bit for bit; against the CPU's exact
// results, the sums stay within the documented bound (docs/accel.md) and the
// configuration risks within 1e-5 relative (the spec's tolerance for a
// fixed-point path) wherever I is not vanishingly small.
#include <cmath>
#include <memory>
#include <vector>

#include "accel/risk_engine.h"
#include "accel_test_util.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::FpgaExpectation;
using testing::MixedConfigs;
using testing::SameRisk;
using testing::ShimProcess;
using testing::SmallCity;

// Window sums of density and shelter for the bound (spec's out-of-map values).
void WindowSums(const RiskModel& model, const KernelSite& s, double* sum_rho, double* sum_s,
                int* cells) {
  const int hw = model.table().kernel(s.height_bin, s.heading_bin).half_width;
  const RiskMap& m = model.map();
  *sum_rho = *sum_s = 0;
  for (int j = s.impact_j - hw; j <= s.impact_j + hw; ++j) {
    for (int i = s.impact_i - hw; i <= s.impact_i + hw; ++i) {
      *sum_rho += m.Contains(i, j) ? m.density(i, j) : 0.0;
      *sum_s += m.Contains(i, j) ? m.shelter(i, j) : 10.0;
    }
  }
  *cells = (2 * hw + 1) * (2 * hw + 1);
}

void CheckBoard(const std::vector<std::string>& shim_args, const NumberFormat& format,
                double risk_tolerance, const RiskModel& model = *SmallCity()) {
  auto shim = ShimProcess::Start(shim_args);
  ASSERT_NE(shim, nullptr);
  std::unique_ptr<RiskEngine> engine = testing::BoardOnlyEngine(shim->endpoint(), 2000);
  ASSERT_NE(engine, nullptr);
  const std::vector<Pose> configs = MixedConfigs(model, 6000, 21);
  std::vector<ConfigurationRisk> out(configs.size());
  ASSERT_TRUE(engine->Evaluate(model, configs, out).ok());
  const RiskEngineStats stats = engine->Stats();
  EXPECT_EQ(stats.fpga[0].configurations, configs.size()) << "every chunk went to the board";
  EXPECT_EQ(stats.fpga[0].hello.format, format);

  const FpgaExpectation board(model, format);
  const QuantizedMap q = *QuantizeMapBlob(EncodeMapBlob(model.map()), format, 8);
  int compared = 0;
  double worst_relative = 0.0;
  for (size_t n = 0; n < configs.size(); ++n) {
    ASSERT_TRUE(SameRisk(out[n], board.Evaluate(configs[n]))) << "configuration " << n;
    const ConfigurationRisk cpu = model.Evaluate(configs[n]);
    ASSERT_EQ(out[n].defined, cpu.defined);
    if (!cpu.defined) continue;
    KernelSite site;
    ASSERT_TRUE(model.Locate(configs[n], &site));
    double sum_rho = 0, sum_s = 0;
    int cells = 0;
    WindowSums(model, site, &sum_rho, &sum_s, &cells);
    const double w = std::ldexp(1.0, -format.weight_frac_bits);
    const double bound_i = w * sum_rho +
                           std::ldexp(1.0, -(q.density_exponent + 1)) * (1 + cells * w) +
                           1e-15 * cpu.impact_factor;
    const double bound_s = w * sum_s +
                           std::ldexp(1.0, -(q.shelter_exponent + 1)) * (1 + cells * w) +
                           1e-15 * cpu.expected_shelter;
    EXPECT_LE(std::abs(out[n].impact_factor - cpu.impact_factor), bound_i) << n;
    EXPECT_LE(std::abs(out[n].expected_shelter - cpu.expected_shelter), bound_s) << n;
    // Relative error of M where I is well above its absolute error bound.
    if (cpu.impact_factor > 1e3 * bound_i) {
      const double rel = std::abs(out[n].risk - cpu.risk) / cpu.risk;
      worst_relative = std::max(worst_relative, rel);
      EXPECT_LE(rel, risk_tolerance) << n;
      ++compared;
    }
  }
  EXPECT_GT(compared, 4000);
  std::cout << format.Name() << ": largest relative error of M over " << compared
            << " configurations: " << worst_relative << "\n";
}

TEST(FpgaAccuracyTest, ModelBackendBoardFormat) {
  CheckBoard({"--device=model", "--format=board"}, NumberFormat::Board(), 1e-5);
}

TEST(FpgaAccuracyTest, ModelBackendPreciseFormat) {
  CheckBoard({"--device=model", "--format=precise"}, NumberFormat::Precise(), 1e-10);
}

// Version 3: in wind the board computes the same sums (the weights do not
// move with the wind); the host locates by the air heading and finishes with
// the (b, k) entry's energy. Within the format's bound of the exact model.
TEST(FpgaAccuracyTest, ModelBackendInWind) {
  CheckBoard({"--device=model", "--format=board"}, NumberFormat::Board(), 1e-5,
             *testing::SmallCityInWind());
  CheckBoard({"--device=model", "--format=precise"}, NumberFormat::Precise(), 1e-10,
             *testing::SmallCityInWind());
}

TEST(FpgaAccuracyTest, MmioBackendOnTheComponentModel) {
  CheckBoard({"--device=mmio", "--mmio_device=model", "--model_lanes=8", "--format=board"},
             NumberFormat::Board(), 1e-5);
}

}  // namespace
}  // namespace riskplan::accel

namespace riskplan::accel {
namespace {

// Spec version 2: a configuration whose impact window reaches past the map has
// no risk. Whatever would compute its sums from padding (the exact CPU
// kernel, the float32 path, a board through the shim with its quantised
// out-of-map values), the engine reports it undefined, and one cell further
// in it reports a number.
TEST(UnknownGroundTest, NoPathReportsARiskForAWindowPastTheMap) {
  const RiskModel& model = *SmallCity();
  const RiskMap& map = model.map();
  // A row of configurations heading west near the west edge, 1 m apart, at
  // 60 m above the ground: the first ones see past the map, the others not.
  std::vector<Pose> configs;
  for (double x = 0.5; x < 200.0; x += 1.0) {
    const double y = 1500.0;
    int i = 0, j = 0;
    ASSERT_TRUE(map.CellOf(x, y, &i, &j));
    configs.push_back(Pose{x, y, map.terrain(i, j) + 60.0, kPi});
  }
  std::vector<bool> defined(configs.size());
  size_t undefined = 0;
  for (size_t n = 0; n < configs.size(); ++n) {
    KernelSite site;
    defined[n] = model.Locate(configs[n], &site);
    undefined += defined[n] ? 0 : 1;
    if (n > 0) {
      ASSERT_LE(defined[n - 1], defined[n]) << "one boundary along the row";
    }
  }
  ASSERT_GT(undefined, 20u);
  ASSERT_LT(undefined, configs.size() - 20);

  const auto check = [&](RiskEngine& engine, const char* which) {
    SCOPED_TRACE(which);
    std::vector<ConfigurationRisk> out(configs.size());
    for (ConfigurationRisk& r : out) r.risk = -1.0;  // sentinel
    ASSERT_TRUE(engine.Evaluate(model, configs, out).ok());
    for (size_t n = 0; n < configs.size(); ++n) {
      ASSERT_EQ(out[n].defined, defined[n]) << "configuration " << n;
      if (defined[n]) {
        EXPECT_TRUE(std::isfinite(out[n].risk) && out[n].risk >= 0.0) << n;
      } else {
        EXPECT_EQ(out[n].risk, 0.0) << n;  // ConfigurationRisk{}: no number
      }
    }
  };
  for (KernelPrecision precision : {KernelPrecision::kExact, KernelPrecision::kFloat32}) {
    RiskEngineOptions options;
    options.cpu_workers = 1;
    options.kernel.precision = precision;
    auto engine = RiskEngine::Create(options);
    ASSERT_TRUE(engine.ok()) << engine.status();
    check(**engine, precision == KernelPrecision::kExact ? "exact" : "float32");
  }
  auto shim = ShimProcess::Start({"--device=model", "--format=board"});
  ASSERT_NE(shim, nullptr);
  std::unique_ptr<RiskEngine> board = testing::BoardOnlyEngine(shim->endpoint(), 2000);
  ASSERT_NE(board, nullptr);
  check(*board, "board");
  // Every chunk went to the board (none came back to the CPU).
  EXPECT_EQ(board->Stats().fpga[0].configurations, configs.size());
  EXPECT_EQ(board->Stats().fpga[0].failures, 0u);
}

}  // namespace
}  // namespace riskplan::accel
