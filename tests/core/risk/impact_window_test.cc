// Spec version 2: ground outside the map is unknown. A configuration whose
// impact window reaches past the map has no risk and is not admissible; the
// reach the model reports is exactly where that starts; the risk layer's
// NODATA band has the reach's width.
#include <cmath>
#include <limits>
#include <vector>

#include "core/base/geometry.h"
#include "core/risk/risk_layer.h"
#include "core/risk/risk_model.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

using testing_maps::UniformMap;

constexpr double kRes = 10.0;
constexpr int kCells = 120;  // 1200 m square
constexpr float kTerrain = 50.0f;

std::shared_ptr<const RiskModel> FlatModel(const ModelParams& params = {}) {
  auto map = UniformMap(kCells, kCells, kRes, 0.01f, 3.0f, kTerrain);
  auto model = RiskModel::Create(map, params);
  EXPECT_TRUE(model.ok()) << model.status();
  return model.ok() ? *model : nullptr;
}

// The impact cell and half-width of q, computed here from the table alone.
struct Window {
  int ci, cj, hw;
};
Window WindowOf(const RiskModel& model, const Pose& q) {
  const ImpactTable& t = model.table();
  const double h = q.z - kTerrain;
  const ImpactKernel& k = t.kernel(t.HeightBinOf(h), t.HeadingBinOf(q.theta));
  return Window{static_cast<int>(std::floor((q.x + k.offset_x_m) / kRes)),
                static_cast<int>(std::floor((q.y + k.offset_y_m) / kRes)), k.half_width};
}

// For each side of the map and heading bins pointing at it (and across it),
// places the window one cell past the edge (inadmissible, undefined) and then
// exactly on the edge (admissible, defined).
TEST(ImpactWindowTest, OneCellPastTheEdgeIsInadmissibleOnTheEdgeIsDefined) {
  auto model = FlatModel();
  ASSERT_NE(model, nullptr);
  const ImpactTable& t = model->table();
  int checked = 0;
  for (double agl : {30.0, 60.0, 100.0, 150.0}) {
    const int b = t.HeightBinOf(agl);
    for (int k = 0; k < t.heading_bins(); k += 3) {
      const double theta = k * kTwoPi / t.heading_bins();
      const ImpactKernel& kernel = t.kernel(b, k);
      const int hw = kernel.half_width;
      const double mid = 0.5 * kCells * kRes;
      // Centres of the cells whose impact cell is `target` on one axis.
      const auto x_for = [&](int target, double offset) { return (target + 0.5) * kRes - offset; };
      struct Side {
        const char* name;
        Pose past;  // window one cell past the edge
        Pose on;    // window's last row or column on the edge
      };
      const Side sides[] = {
          {"west",
           {x_for(hw - 1, kernel.offset_x_m), mid, kTerrain + agl, theta},
           {x_for(hw, kernel.offset_x_m), mid, kTerrain + agl, theta}},
          {"east",
           {x_for(kCells - hw, kernel.offset_x_m), mid, kTerrain + agl, theta},
           {x_for(kCells - 1 - hw, kernel.offset_x_m), mid, kTerrain + agl, theta}},
          {"south",
           {mid, x_for(hw - 1, kernel.offset_y_m), kTerrain + agl, theta},
           {mid, x_for(hw, kernel.offset_y_m), kTerrain + agl, theta}},
          {"north",
           {mid, x_for(kCells - hw, kernel.offset_y_m), kTerrain + agl, theta},
           {mid, x_for(kCells - 1 - hw, kernel.offset_y_m), kTerrain + agl, theta}},
      };
      for (const Side& side : sides) {
        SCOPED_TRACE(testing::Message() << side.name << " agl=" << agl << " k=" << k);
        // Both configurations must lie inside the map for the case to test
        // the window rule (an aircraft over the map).
        int i = 0, j = 0;
        if (!model->map().CellOf(side.past.x, side.past.y, &i, &j) ||
            !model->map().CellOf(side.on.x, side.on.y, &i, &j)) {
          continue;
        }
        const Window past = WindowOf(*model, side.past);
        const Window on = WindowOf(*model, side.on);
        // The construction puts the windows where they should be.
        const int past_margin =
            std::min({past.ci - past.hw, past.cj - past.hw, kCells - 1 - past.ci - past.hw,
                      kCells - 1 - past.cj - past.hw});
        const int on_margin = std::min(
            {on.ci - on.hw, on.cj - on.hw, kCells - 1 - on.ci - on.hw, kCells - 1 - on.cj - on.hw});
        ASSERT_EQ(past_margin, -1);
        ASSERT_EQ(on_margin, 0);

        EXPECT_EQ(model->CheckConfiguration(side.past), ViolationKind::kImpactOutsideMap);
        EXPECT_FALSE(model->Evaluate(side.past).defined);
        KernelSite site;
        EXPECT_FALSE(model->Locate(side.past, &site));

        EXPECT_EQ(model->CheckConfiguration(side.on), ViolationKind::kNone);
        const ConfigurationRisk r = model->Evaluate(side.on);
        ASSERT_TRUE(r.defined);
        // Uniform layers: the sums are the layer values exactly when every
        // weight falls on the map.
        EXPECT_NEAR(r.impact_factor, static_cast<double>(0.01f), 1e-15);
        EXPECT_NEAR(r.expected_shelter, 3.0, 1e-13);
        ++checked;
      }
    }
  }
  // Every side with every fourth heading bin, at four heights (a few cases
  // place the aircraft itself past the map and are skipped).
  EXPECT_GE(checked, 4 * 4 * 18 * 3 / 4);
}

TEST(ImpactWindowTest, WindowRuleComesAfterTheAltitudeRules) {
  auto model = FlatModel();
  ASSERT_NE(model, nullptr);
  // 5 m from the west edge heading west: the window reaches past the map,
  // but the altitude rules are checked first.
  double limit = 0.0;
  EXPECT_EQ(model->CheckConfiguration(Pose{5.0, 600.0, kTerrain + 10.0, kPi}, &limit),
            ViolationKind::kBelowSafeAltitude);
  EXPECT_EQ(model->CheckConfiguration(Pose{5.0, 600.0, kTerrain + 200.0, kPi}, &limit),
            ViolationKind::kAboveMaxAltitude);
  EXPECT_EQ(model->CheckConfiguration(Pose{5.0, 600.0, kTerrain + 60.0, kPi}, &limit),
            ViolationKind::kImpactOutsideMap);
  EXPECT_TRUE(std::isnan(limit));
  // A heading that is not finite is not a configuration.
  EXPECT_EQ(model->CheckConfiguration(Pose{600.0, 600.0, kTerrain + 60.0, std::nan("")}),
            ViolationKind::kOutsideMap);
  EXPECT_EQ(ViolationKindName(ViolationKind::kImpactOutsideMap), "IMPACT_OUTSIDE_MAP");
}

// Reach(h) says exactly where M becomes defined for every heading: checked
// cell by cell against Evaluate over all 72 heading bins.
TEST(ImpactWindowTest, ReachAndClearCellsMatchEvaluationCellByCell) {
  auto model = FlatModel();
  ASSERT_NE(model, nullptr);
  const RiskMap& map = model->map();
  for (double agl : {30.0, 150.0}) {
    SCOPED_TRACE(agl);
    const ImpactReach reach = model->Reach(agl);
    EXPECT_GT(reach.Max(), 0.0);
    EXPECT_EQ(reach.height_bin, model->table().HeightBinOf(agl));
    int64_t all_defined = 0;
    for (int j = 0; j < kCells; ++j) {
      for (int i = 0; i < kCells; ++i) {
        const double x = (i + 0.5) * kRes;
        const double y = (j + 0.5) * kRes;
        bool every = true;
        for (int k = 0; k < model->table().heading_bins() && every; ++k) {
          every = model->Evaluate(Pose{x, y, kTerrain + agl, k * kTwoPi / 72}).defined;
        }
        const bool clear = x >= reach.west_m && kCells * kRes - x > reach.east_m &&
                           y >= reach.south_m && kCells * kRes - y > reach.north_m;
        ASSERT_EQ(every, clear) << "cell " << i << ", " << j;
        all_defined += every ? 1 : 0;
      }
    }
    EXPECT_EQ(reach.CellsClear(map), all_defined);
    EXPECT_GT(all_defined, 0);
    EXPECT_LT(all_defined, int64_t{kCells} * kCells);
  }
  // A higher fall reaches farther.
  EXPECT_GT(model->Reach(150.0).Max(), model->Reach(30.0).Max());
}

// The conservative whole-cell margins: inside them no height in the flight
// band and no heading breaks the window rule.
TEST(ImpactWindowTest, BandMarginsAreConservative) {
  auto model = FlatModel();
  ASSERT_NE(model, nullptr);
  const CellMargins& m = model->band_margins();
  EXPECT_GT(m.west, 0);
  EXPECT_GT(m.north, 0);
  const ModelParams& p = model->params();
  for (int j = 0; j < kCells; ++j) {
    for (int i = 0; i < kCells; ++i) {
      if (!m.Inside(i, j, kCells, kCells)) continue;
      // Corners and centre of the cell, lowest and highest altitude of the
      // band, and four headings between bins.
      for (double fx : {0.0, 0.5, 0.999999}) {
        for (double fy : {0.0, 0.999999}) {
          for (double agl : {p.min_agl_m, 0.5 * (p.min_agl_m + p.max_agl_m), p.max_agl_m}) {
            for (double theta : {0.03, 1.6, 3.1, 4.7}) {
              const Pose q{(i + fx) * kRes, (j + fy) * kRes, kTerrain + agl, theta};
              ASSERT_EQ(model->CheckConfiguration(q), ViolationKind::kNone)
                  << i << ", " << j << " agl " << agl << " theta " << theta;
            }
          }
        }
      }
    }
  }
}

// Near the edges, below WindowCeilingAgl no height of the flight band and no
// heading breaks the window rule; the ceiling only rises going inwards.
TEST(ImpactWindowTest, WindowCeilingIsConservativeAndRisesInwards) {
  auto model = FlatModel();
  ASSERT_NE(model, nullptr);
  const ModelParams& p = model->params();
  const int j = kCells / 2;
  int finite = 0;
  double previous = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < kCells / 2; ++i) {
    const double cap = model->WindowCeilingAgl(i, j);
    EXPECT_GE(cap, previous) << i;
    previous = cap;
    if (std::isinf(cap)) {
      EXPECT_EQ(cap > 0, model->band_margins().Inside(i, j, kCells, kCells)) << i;
      continue;
    }
    ++finite;
    for (double agl = p.min_agl_m; agl < cap; agl += 0.5) {
      for (double fx : {0.0, 0.5, 0.999999}) {
        for (int k = 0; k < 72; ++k) {
          const Pose q{(i + fx) * kRes, (j + 0.5) * kRes, kTerrain + agl, (k + 0.4) * kTwoPi / 72};
          ASSERT_EQ(model->CheckConfiguration(q), ViolationKind::kNone)
              << i << " agl " << agl << " k " << k;
        }
      }
    }
  }
  // Between the closed edge and the band margins, cells with a lower ceiling.
  EXPECT_GT(finite, 2);
}

// The risk layer's NODATA band (NaN) is exactly the reach: at a fixed height
// above the ground, the maximum over headings is defined where every heading
// is.
TEST(ImpactWindowTest, RiskLayerNodataBandHasTheReachWidth) {
  auto model = FlatModel();
  ASSERT_NE(model, nullptr);
  for (double agl : {30.0, 150.0}) {
    SCOPED_TRACE(agl);
    RiskLayerOptions options;
    options.height_agl_m = agl;
    options.heading_rad = std::nan("");  // the maximum over every heading bin
    options.threads = 2;
    auto layer = ComputeRiskLayer(*model, options);
    ASSERT_TRUE(layer.ok()) << layer.status();
    const ImpactReach reach = model->Reach(agl);
    // Width of the band in cells on each side, from the reach.
    const auto band = [&](double reach_m, bool strict) {
      int n = 0;
      while (n < kCells && (strict ? (n + 0.5) * kRes <= reach_m : (n + 0.5) * kRes < reach_m)) ++n;
      return n;
    };
    const int west = band(reach.west_m, false);
    const int east = band(reach.east_m, true);
    const int south = band(reach.south_m, false);
    const int north = band(reach.north_m, true);
    EXPECT_GT(west, 0);
    EXPECT_GT(east, 0);
    int64_t nan_cells = 0;
    for (int r = 0; r < layer->ny; ++r) {
      for (int c = 0; c < layer->nx; ++c) {
        const double m = layer->risk[static_cast<size_t>(r) * layer->nx + c];
        const bool in_band = c < west || c >= kCells - east || r < south || r >= kCells - north;
        ASSERT_EQ(std::isnan(m), in_band) << "cell " << c << ", " << r;
        if (!in_band) {
          EXPECT_GT(m, 0.0);
        }
        nan_cells += std::isnan(m) ? 1 : 0;
      }
    }
    EXPECT_EQ(nan_cells, int64_t{kCells} * kCells - reach.CellsClear(model->map()));
  }
}

}  // namespace
}  // namespace riskplan
