// The spot check FpgaWorker runs on board replies (accel/board_audit.h): the
// exact fixed-point sums of a correct datapath always pass, in both formats,
// on configurations inside, across and beyond the map's edge; sums off by
// more than the format's bound, or NaN, are refused with a message naming
// the site. And the blob cache refuses a blob larger than its budget rather
// than holding more than it may.
#include "accel/board_audit.h"

#include <cmath>
#include <vector>

#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel_test_util.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::MixedConfigs;
using testing::SmallCity;

struct BoardSums {
  KernelSite site;
  double impact = 0.0;
  double shelter = 0.0;
};

// The sums a correct board with `format` returns for every defined
// configuration of `configs`, and the scales the worker checks them with.
std::vector<BoardSums> CorrectBoard(const RiskModel& model, const std::vector<Pose>& configs,
                                    const NumberFormat& format, BoardScales* scales) {
  const QuantizedMap map = *QuantizeMapBlob(EncodeMapBlob(model.map()), format, 32);
  const QuantizedKernelTable kernels =
      *QuantizeKernelsBlob(EncodeKernelsBlob(KernelSetOf(model.table())), format, 63);
  *scales = BoardScales{format, map.density_exponent, map.shelter_exponent};
  std::vector<BoardSums> out;
  for (const Pose& q : configs) {
    BoardSums b;
    if (!model.Locate(q, &b.site)) continue;
    Accumulator impact = 0, shelter = 0;
    ModelEwmm(map, kernels.kernel(b.site.height_bin, b.site.heading_bin), b.site.impact_i,
              b.site.impact_j, &impact, &shelter);
    b.impact = AccumulatorToDouble(impact, format.weight_frac_bits + map.density_exponent);
    b.shelter = AccumulatorToDouble(shelter, format.weight_frac_bits + map.shelter_exponent);
    out.push_back(b);
  }
  return out;
}

TEST(BoardAuditTest, CorrectSumsPassInBothFormats) {
  const RiskModel& model = *SmallCity();
  const std::vector<Pose> configs = MixedConfigs(model, 3000, 31);
  for (const NumberFormat& format : {NumberFormat::Board(), NumberFormat::Precise()}) {
    BoardScales scales;
    const std::vector<BoardSums> sums = CorrectBoard(model, configs, format, &scales);
    // Most are defined (the rest lie outside the map, under the terrain or
    // with their impact windows past the map).
    ASSERT_GT(sums.size(), 2500u);
    for (const BoardSums& b : sums) {
      ASSERT_TRUE(AuditBoardSums(model, b.site, scales, b.impact, b.shelter).ok())
          << format.Name() << " cell " << b.site.impact_i << ", " << b.site.impact_j;
    }
  }
}

TEST(BoardAuditTest, WrongSumsAreRefused) {
  const RiskModel& model = *SmallCity();
  BoardScales scales;
  const std::vector<BoardSums> sums =
      CorrectBoard(model, MixedConfigs(model, 400, 32), NumberFormat::Board(), &scales);
  int refused_impact = 0, refused_shelter = 0;
  for (const BoardSums& b : sums) {
    // Off by more than the bound: 1e-6 absolute is far above the bound on I
    // on this map (about 1e-8), 3e-6 above the bound on S~ for the widest
    // windows of these configurations (about 2e-6 at 200 m above ground).
    refused_impact += !AuditBoardSums(model, b.site, scales, b.impact + 1e-6, b.shelter).ok();
    refused_shelter += !AuditBoardSums(model, b.site, scales, b.impact, b.shelter + 3e-6).ok();
    EXPECT_FALSE(AuditBoardSums(model, b.site, scales, std::nan(""), b.shelter).ok());
    EXPECT_FALSE(AuditBoardSums(model, b.site, scales, b.impact, -b.shelter - 1.0).ok());
  }
  EXPECT_EQ(refused_impact, static_cast<int>(sums.size()));
  EXPECT_EQ(refused_shelter, static_cast<int>(sums.size()));
  const BoardSums& b = sums.front();
  const absl::Status s = AuditBoardSums(model, b.site, scales, b.impact * 2 + 1e-3, b.shelter);
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(s.message().find("w32m32a80"), absl::string_view::npos) << s;
  EXPECT_NE(s.message().find(absl::StrCat("cell ", b.site.impact_i, ", ", b.site.impact_j)),
            absl::string_view::npos)
      << s;
}

TEST(BlobCacheTest, ABlobLargerThanTheBudgetIsRefusedNotKept) {
  const std::shared_ptr<const RiskModel> model = SmallCity();
  BlobCache small(1 << 20);  // the 3 km map's blob is about 2.9 MB
  EXPECT_EQ(small.MapBlob(model->map_ptr()), nullptr);
  EXPECT_EQ(small.MapBlob(model->map_ptr()), nullptr) << "refused again, not rebuilt and kept";
  EXPECT_EQ(small.MemoryBytes(), 0u);
  BlobCache big(size_t{64} << 20);
  const std::shared_ptr<const Blob> blob = big.MapBlob(model->map_ptr());
  ASSERT_NE(blob, nullptr);
  EXPECT_GT(blob->bytes.size(), size_t{1} << 20);
  EXPECT_EQ(big.MemoryBytes(), blob->bytes.size());
  EXPECT_EQ(big.MapBlob(model->map_ptr()), blob);
}

}  // namespace
}  // namespace riskplan::accel
