#include "core/flight/piece_risk.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

TEST(PartCountTest, CountsInSixtyFourBitsAndSaturates) {
  EXPECT_EQ(PartCount(0.0, 5.0), 0);
  EXPECT_EQ(PartCount(-1.0, 5.0), 0);
  EXPECT_EQ(PartCount(12.0, 5.0), 3);
  // Past 2^31 the count is exact, not wrapped to a negative int.
  EXPECT_EQ(PartCount(3e9, 1.0), int64_t{3000000000});
  EXPECT_EQ(PartCount(4e18, 1.0), int64_t{4000000000000000000});
  // What does not fit saturates, so any bound on the count catches it.
  EXPECT_EQ(PartCount(1e19, 1e-7), kMaxPartCount);
  EXPECT_EQ(PartCount(std::numeric_limits<double>::infinity(), 5.0), kMaxPartCount);
  // A length that overflowed into NaN cannot be sampled: over any bound too.
  EXPECT_EQ(PartCount(std::nan(""), 5.0), kMaxPartCount);
  EXPECT_EQ(PartCount(std::ldexp(1.0, 62), 1.0), kMaxPartCount);
  EXPECT_EQ(PartCount(std::ldexp(1.0, 61), 1.0), int64_t{1} << 61);
}

TEST(PieceRiskTest, MidpointsAndAdmissibilitySamplesInOrderOfArcLength) {
  // 12 m with a 5 m step: K = 3, ds = 4.
  const TrajectoryPiece piece = TrajectoryPiece::Segment({100, 200, 50}, {112, 200, 50});
  const PieceRisk rule(piece, 5.0, ModelParams{});
  ASSERT_EQ(rule.parts(), 3);
  EXPECT_EQ(rule.part_length_m(), 4.0);
  EXPECT_EQ(rule.MidpointArc(0), 2.0);
  EXPECT_EQ(rule.MidpointArc(2), 10.0);
  EXPECT_EQ(rule.Midpoint(1).x, 106.0);
  ASSERT_EQ(rule.admissibility_samples(), 5);
  const double want_arc[] = {0.0, 2.0, 6.0, 10.0, 12.0};
  const double want_x[] = {100.0, 102.0, 106.0, 110.0, 112.0};
  for (int64_t i = 0; i < 5; ++i) {
    double arc = -1.0;
    const Pose q = rule.AdmissibilitySample(i, &arc);
    EXPECT_EQ(arc, want_arc[i]) << i;
    EXPECT_EQ(q.x, want_x[i]) << i;
  }
  std::vector<Pose> some;
  rule.AppendMidpoints(1, 3, &some);
  ASSERT_EQ(some.size(), 2u);
  EXPECT_EQ(some[0].x, 106.0);
  EXPECT_EQ(some[1].x, 110.0);
}

TEST(PieceRiskTest, ZeroLengthPieceHasNoMidpointsAndZeroRisk) {
  const PieceRisk rule(TrajectoryPiece::Segment({1, 2, 3}, {1, 2, 3}), 5.0, ModelParams{});
  EXPECT_EQ(rule.parts(), 0);
  EXPECT_TRUE(rule.complete());
  EXPECT_EQ(rule.Risk(), 0.0);
  EXPECT_EQ(rule.admissibility_samples(), 2);  // start and end
}

TEST(PieceRiskTest, PartialRiskGrowsToTheRiskAndUndefinedAddsNothing) {
  ModelParams params;
  PieceRisk rule(TrajectoryPiece::Segment({0, 0, 100}, {20, 0, 100}), 5.0, params);
  ASSERT_EQ(rule.parts(), 4);
  const double per_metre = params.failure_rate_per_s / params.airspeed_mps;
  ConfigurationRisk m;
  m.defined = true;
  double previous = 0.0;
  for (double value : {1e-3, 2e-3, 0.0}) {
    m.risk = value;
    rule.Add(m, Pose{});
    EXPECT_GE(rule.PartialRisk(), previous);
    previous = rule.PartialRisk();
  }
  ConfigurationRisk undefined;
  undefined.risk = 0.5;  // ignored: an undefined M adds nothing
  rule.Add(undefined, Pose{});
  ASSERT_TRUE(rule.complete());
  EXPECT_EQ(rule.Risk(), per_metre * ((0.0 + 1e-3) + 2e-3 + 0.0) * 5.0);
}

// The rule's risk is EvaluateTrajectory's piece risk, bit for bit, however the
// midpoints are batched.
TEST(PieceRiskTest, ChunkedSumsEqualEvaluateTrajectoryBitForBit) {
  auto map = MakeDemoCity();
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok()) << model.status();
  const ModelParams& mp = (*model)->params();
  const std::vector<Pose> waypoints = {
      {1200, 1500, 250, 0.785}, {3000, 2600, 240, 1.2}, {4100, 4300, 260, 0.3}};
  auto pieces = PiecesFromWaypoints(waypoints, mp);
  ASSERT_TRUE(pieces.ok());
  auto evaluation = EvaluateTrajectory(**model, *pieces);
  ASSERT_TRUE(evaluation.ok());
  for (size_t p = 0; p < pieces->size(); ++p) {
    for (int64_t chunk : {int64_t{1}, int64_t{7}, int64_t{16}, int64_t{1} << 40, kMaxPartCount}) {
      PieceRisk rule((*pieces)[p], mp.sample_step_m, mp);
      while (!rule.complete()) {
        const int64_t end = std::min(rule.parts(), rule.added() + chunk);
        EXPECT_EQ(rule.ChunkEnd(chunk), end);
        std::vector<Pose> batch;
        rule.AppendMidpoints(rule.added(), end, &batch);
        for (const Pose& q : batch) rule.Add((*model)->Evaluate(q), q);
        EXPECT_LE(rule.PartialRisk(), evaluation->pieces[p].risk);
      }
      EXPECT_EQ(rule.Risk(), evaluation->pieces[p].risk) << "piece " << p << " chunk " << chunk;
      EXPECT_EQ(rule.parts(), evaluation->pieces[p].parts);
    }
  }
}

}  // namespace
}  // namespace riskplan
