#include "core/flight/trajectory.h"

#include <cmath>
#include <vector>

#include "core/map/demo_city.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

using testing_maps::UniformMap;

class TrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    map_ = UniformMap(400, 400, 5.0, 0.02f, 3.0f, 100.0f);
    ASSERT_NE(map_, nullptr);
    auto model = RiskModel::Create(map_, params_);
    ASSERT_TRUE(model.ok()) << model.status();
    model_ = *model;
  }
  ModelParams params_;
  std::shared_ptr<const RiskMap> map_;
  std::shared_ptr<const RiskModel> model_;
};

TEST_F(TrajectoryTest, StraightSegmentOnUniformMapIsConstantRateTimesLength) {
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{300, 1000, 200}, {1700, 1000, 200}});
  ASSERT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(*model_, *pieces, {.keep_samples = true});
  ASSERT_TRUE(eval.ok());
  EXPECT_TRUE(eval->admissible);
  EXPECT_DOUBLE_EQ(eval->length_m, 1400.0);
  ASSERT_EQ(eval->pieces.size(), 1u);
  EXPECT_EQ(eval->pieces[0].parts, 280);
  ASSERT_EQ(eval->samples.size(), 280u);
  const double m = model_->Evaluate(Pose{1000, 1000, 200, 0}).risk;
  const double expected = params_.failure_rate_per_s * m * 1400.0 / params_.airspeed_mps;
  EXPECT_NEAR(eval->risk, expected, 1e-12 * expected);
  EXPECT_DOUBLE_EQ(eval->samples[0].arc_length_m, 2.5);
  EXPECT_DOUBLE_EQ(eval->samples[0].pose.x, 302.5);
  EXPECT_DOUBLE_EQ(eval->samples.back().arc_length_m, 1397.5);
}

TEST_F(TrajectoryTest, PartCountIsCeilOfLengthOverStep) {
  EXPECT_EQ(PartCount(0.0, 5.0), 0);
  EXPECT_EQ(PartCount(0.1, 5.0), 1);
  EXPECT_EQ(PartCount(5.0, 5.0), 1);
  EXPECT_EQ(PartCount(5.01, 5.0), 2);
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{300, 300, 200}, {312, 300, 200}});
  ASSERT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(*model_, *pieces, {.keep_samples = true});
  ASSERT_TRUE(eval.ok());
  ASSERT_EQ(eval->samples.size(), 3u);
  EXPECT_DOUBLE_EQ(eval->samples[0].arc_length_m, 2.0);  // ds = 4
  EXPECT_DOUBLE_EQ(eval->samples[1].arc_length_m, 6.0);
  EXPECT_DOUBLE_EQ(eval->samples[2].arc_length_m, 10.0);
}

TEST_F(TrajectoryTest, RiskIsTheSumOfItsPieces) {
  const std::vector<Pose> waypoints = {
      {300, 300, 180, 0.0}, {900, 500, 200, 1.0}, {1200, 1200, 230, 2.5}, {600, 1500, 190, 4.0}};
  auto pieces = PiecesFromWaypoints(waypoints, params_);
  ASSERT_TRUE(pieces.ok());
  auto whole = EvaluateTrajectory(*model_, *pieces);
  ASSERT_TRUE(whole.ok());
  EXPECT_TRUE(whole->admissible) << whole->first_violation->ToString();
  double sum = 0.0;
  double length = 0.0;
  for (size_t p = 0; p < pieces->size(); ++p) {
    auto one = EvaluateTrajectory(*model_, std::span(&(*pieces)[p], 1));
    ASSERT_TRUE(one.ok());
    EXPECT_DOUBLE_EQ(one->risk, whole->pieces[p].risk);
    sum += one->risk;
    length += one->length_m;
  }
  EXPECT_NEAR(whole->risk, sum, 1e-15 * sum);
  EXPECT_NEAR(whole->length_m, length, 1e-9);
  EXPECT_GT(whole->risk, 0.0);
}

TEST_F(TrajectoryTest, FirstViolationHasKindPositionAndArcLength) {
  // Climbs out of the band: ceiling is 100 + 150 = 250 m.
  auto pieces = PiecesFromPolyline(
      std::vector<Point3>{{500, 1000, 200}, {1500, 1000, 200}, {1500, 1100, 300}});
  ASSERT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(*model_, *pieces);
  ASSERT_TRUE(eval.ok());
  EXPECT_FALSE(eval->admissible);
  ASSERT_TRUE(eval->first_violation.has_value());
  const Violation& v = *eval->first_violation;
  EXPECT_EQ(v.kind, ViolationKind::kAboveMaxAltitude);
  EXPECT_EQ(v.piece, 1);
  EXPECT_TRUE(eval->pieces[0].admissible);
  EXPECT_FALSE(eval->pieces[1].admissible);
  // The second piece (length sqrt(2)*100) is cut in 29 parts; the first sample
  // above 250 m is the first midpoint whose climb exceeds 50 m.
  const double len = std::sqrt(2.0) * 100.0;
  const double ds = len / 29;
  int first = 0;
  while (200.0 + 100.0 * (first + 0.5) * ds / len <= 250.0) ++first;
  EXPECT_NEAR(v.arc_length_m, 1000.0 + (first + 0.5) * ds, 1e-9);
  EXPECT_NEAR(v.pose.z, 200.0 + 100.0 * (first + 0.5) * ds / len, 1e-9);
  EXPECT_EQ(v.limit_m, 250.0);
  EXPECT_NE(v.ToString().find("ABOVE_MAX_ALTITUDE"), std::string::npos);
}

TEST_F(TrajectoryTest, EndpointOutsideMapIsAViolation) {
  // Flying in from the border: the start (x = 2000) is outside.
  auto in = PiecesFromPolyline(std::vector<Point3>{{2000, 1000, 200}, {1000, 1000, 200}});
  ASSERT_TRUE(in.ok());
  auto eval = EvaluateTrajectory(*model_, *in);
  ASSERT_TRUE(eval.ok());
  EXPECT_FALSE(eval->admissible);
  EXPECT_EQ(eval->first_violation->kind, ViolationKind::kOutsideMap);
  EXPECT_EQ(eval->first_violation->arc_length_m, 0.0);
  // Flying out to it: well before the border, a fall's impact window reaches
  // past the map (spec version 2), so that is the first violation.
  auto out = PiecesFromPolyline(std::vector<Point3>{{1000, 1000, 200}, {2000, 1000, 200}});
  ASSERT_TRUE(out.ok());
  eval = EvaluateTrajectory(*model_, *out);
  ASSERT_TRUE(eval.ok());
  EXPECT_FALSE(eval->admissible);
  EXPECT_EQ(eval->first_violation->kind, ViolationKind::kImpactOutsideMap);
  EXPECT_GT(eval->first_violation->arc_length_m, 800.0);
  EXPECT_LT(eval->first_violation->arc_length_m, 1000.0);
  EXPECT_TRUE(std::isnan(eval->first_violation->limit_m));
  EXPECT_NE(eval->first_violation->ToString().find("IMPACT_OUTSIDE_MAP"), std::string::npos);
  // The sample just before it is defined, and the one reported is not.
  const Pose& q = eval->first_violation->pose;
  EXPECT_FALSE(model_->Evaluate(q).defined);
}

TEST_F(TrajectoryTest, BadInputIsRefusedWithIndexAndValue) {
  auto one = PiecesFromPolyline(std::vector<Point3>{{1, 2, 3}});
  ASSERT_FALSE(one.ok());
  EXPECT_NE(one.status().message().find("at least 2"), std::string::npos);
  auto nan = PiecesFromWaypoints(std::vector<Pose>{{0, 0, 0, 0}, {1, std::nan(""), 0, 0}}, params_);
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.status().message().find("waypoints[1].y"), std::string::npos) << nan.status();
  auto many = PiecesFromPolyline(std::vector<Point3>(11), 10);
  ASSERT_FALSE(many.ok());
  EXPECT_NE(many.status().message().find("at most 10"), std::string::npos);
}

// A trajectory of more than kEvaluationBatch midpoints is evaluated in
// several batches: the risks, the first violation and the samples are those
// of the piece-risk rule applied midpoint by midpoint, as one batch gave them.
TEST(EvaluateTrajectoryBatchesTest, ManyBatchesGiveWhatTheRuleGivesBitForBit) {
  auto map = MakeDemoCity();
  ASSERT_TRUE(map.ok()) << map.status();
  ModelParams params;
  params.sample_step_m = 0.1;
  auto model = RiskModel::Create(*map, params);
  ASSERT_TRUE(model.ok()) << model.status();
  // Over a dense centre, a repeated point (a piece of length 0), then into
  // the ground and out of the map: violations after the first batch.
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{1200, 1500, 250},
                                                       {6800, 6500, 260},
                                                       {6800, 6500, 260},
                                                       {7000, 6000, 250},
                                                       {7200, 6000, 20},
                                                       {9000, 6000, 250}});
  ASSERT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(**model, *pieces, {.keep_samples = true});
  ASSERT_TRUE(eval.ok()) << eval.status();
  int64_t total = 0;
  for (const PieceEvaluation& p : eval->pieces) total += p.parts;
  ASSERT_GT(total, static_cast<int64_t>(kEvaluationBatch));

  // The rule, midpoint by midpoint.
  double risk = 0.0;
  double start_s = 0.0;
  std::optional<Violation> first;
  size_t sample = 0;
  for (size_t p = 0; p < pieces->size(); ++p) {
    PieceRisk rule((*pieces)[p], params.sample_step_m, params);
    bool admissible = true;
    for (int64_t i = 0; i < rule.admissibility_samples(); ++i) {
      double s = 0.0;
      const Pose q = rule.AdmissibilitySample(i, &s);
      if (i >= 1 && i <= rule.parts()) {
        const ConfigurationRisk m = (*model)->Evaluate(q);
        rule.Add(m, q);
        ASSERT_LT(sample, eval->samples.size());
        const SampleEvaluation& got = eval->samples[sample++];
        ASSERT_EQ(got.pose.x, q.x);
        ASSERT_EQ(got.arc_length_m, start_s + s);
        ASSERT_EQ(got.risk.risk, m.risk);
        ASSERT_EQ(got.piece, static_cast<int>(p));
      }
      double limit = 0.0;
      const ViolationKind kind = (*model)->CheckConfiguration(q, &limit);
      if (kind == ViolationKind::kNone) continue;
      admissible = false;
      if (!first.has_value()) first = Violation{kind, q, start_s + s, static_cast<int>(p), limit};
    }
    EXPECT_EQ(eval->pieces[p].risk, rule.Risk()) << p;
    EXPECT_EQ(eval->pieces[p].admissible, admissible) << p;
    risk += rule.Risk();
    start_s += (*pieces)[p].Length();
  }
  EXPECT_EQ(sample, eval->samples.size());
  EXPECT_EQ(eval->risk, risk);
  EXPECT_EQ(eval->length_m, start_s);
  ASSERT_TRUE(first.has_value());
  ASSERT_TRUE(eval->first_violation.has_value());
  EXPECT_EQ(eval->first_violation->kind, first->kind);
  EXPECT_EQ(eval->first_violation->arc_length_m, first->arc_length_m);
  EXPECT_EQ(eval->first_violation->piece, first->piece);
  EXPECT_FALSE(eval->admissible);

  // Stopped between batches.
  CancellationToken token;
  token.Cancel();
  EXPECT_EQ(
      EvaluateTrajectory(**model, *pieces, {}, nullptr, StopCondition(&token)).status().code(),
      absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace riskplan
