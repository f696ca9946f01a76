// EvaluateRisk's fast path (issue 14 part 5): EvaluateTrajectory through
// accel's exact kernel on the calling thread, with the midpoints' window rule
// read from their M, must give what the straightforward core path gives, bit
// for bit: every piece sampled by PieceRisk, RiskModel::Evaluate per
// midpoint, RiskModel::CheckConfiguration (locating again) per admissibility
// sample. That reference is written out below, independently of
// EvaluateTrajectory, and compared on many trajectories: flyable ones,
// inadmissible ones (no-fly zones, terrain, too high, too low, outside the
// map) and ones whose impact windows reach past the map's edge.
#include "accel/kernel_evaluator.h"

#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "accel_test_util.h"
#include "core/base/random.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::SmallCity;

// Main's EvaluateTrajectory before the fast path, one sample at a time.
TrajectoryEvaluation Reference(const RiskModel& model, std::span<const TrajectoryPiece> pieces,
                               bool keep_samples) {
  const ModelParams& params = model.params();
  TrajectoryEvaluation out;
  double start_s = 0.0;
  for (size_t p = 0; p < pieces.size(); ++p) {
    PieceRisk rule(pieces[p], params.sample_step_m, params);
    PieceEvaluation piece;
    piece.length_m = pieces[p].Length();
    piece.parts = rule.parts();
    for (int64_t i = 0; i < rule.admissibility_samples(); ++i) {
      double s = 0.0;
      const Pose q = rule.AdmissibilitySample(i, &s);
      if (i >= 1 && i <= rule.parts()) {
        const ConfigurationRisk m = model.Evaluate(q);
        rule.Add(m, q);
        if (keep_samples) {
          out.samples.push_back(SampleEvaluation{q, start_s + s, static_cast<int>(p), m});
        }
      }
      double limit = 0.0;
      const ViolationKind kind = model.CheckConfiguration(q, &limit);
      if (kind == ViolationKind::kNone) continue;
      piece.admissible = false;
      out.admissible = false;
      if (!out.first_violation.has_value()) {
        out.first_violation = Violation{kind, q, start_s + s, static_cast<int>(p), limit};
      }
    }
    piece.risk = rule.Risk();
    out.risk += piece.risk;
    out.pieces.push_back(piece);
    start_s += pieces[p].Length();
  }
  out.length_m = start_s;
  return out;
}

// Bit for bit (NaN equal to NaN of the same bits).
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void ExpectSamePose(const Pose& a, const Pose& b, const std::string& where) {
  EXPECT_TRUE(SameBits(a.x, b.x) && SameBits(a.y, b.y) && SameBits(a.z, b.z) &&
              SameBits(a.theta, b.theta))
      << where;
}

void ExpectSame(const TrajectoryEvaluation& want, const TrajectoryEvaluation& got,
                const std::string& what) {
  EXPECT_TRUE(SameBits(want.risk, got.risk)) << what << ": " << want.risk << " vs " << got.risk;
  EXPECT_TRUE(SameBits(want.length_m, got.length_m)) << what;
  EXPECT_EQ(want.admissible, got.admissible) << what;
  ASSERT_EQ(want.first_violation.has_value(), got.first_violation.has_value()) << what;
  if (want.first_violation.has_value()) {
    const Violation& a = *want.first_violation;
    const Violation& b = *got.first_violation;
    EXPECT_EQ(a.kind, b.kind) << what << ": " << a.ToString() << " vs " << b.ToString();
    ExpectSamePose(a.pose, b.pose, what + " violation pose");
    EXPECT_TRUE(SameBits(a.arc_length_m, b.arc_length_m)) << what;
    EXPECT_EQ(a.piece, b.piece) << what;
    EXPECT_TRUE(SameBits(a.limit_m, b.limit_m)) << what;
    EXPECT_EQ(a.ToString(), b.ToString()) << what;
  }
  ASSERT_EQ(want.pieces.size(), got.pieces.size()) << what;
  for (size_t p = 0; p < want.pieces.size(); ++p) {
    EXPECT_TRUE(SameBits(want.pieces[p].risk, got.pieces[p].risk)) << what << " piece " << p;
    EXPECT_TRUE(SameBits(want.pieces[p].length_m, got.pieces[p].length_m)) << what;
    EXPECT_EQ(want.pieces[p].parts, got.pieces[p].parts) << what;
    EXPECT_EQ(want.pieces[p].admissible, got.pieces[p].admissible) << what << " piece " << p;
  }
  ASSERT_EQ(want.samples.size(), got.samples.size()) << what;
  for (size_t k = 0; k < want.samples.size(); ++k) {
    const SampleEvaluation& a = want.samples[k];
    const SampleEvaluation& b = got.samples[k];
    const std::string where = what + " sample " + std::to_string(k);
    ExpectSamePose(a.pose, b.pose, where);
    EXPECT_TRUE(SameBits(a.arc_length_m, b.arc_length_m)) << where;
    EXPECT_EQ(a.piece, b.piece) << where;
    EXPECT_EQ(a.risk.defined, b.risk.defined) << where;
    EXPECT_TRUE(SameBits(a.risk.risk, b.risk.risk)) << where;
    EXPECT_TRUE(SameBits(a.risk.impact_factor, b.risk.impact_factor)) << where;
    EXPECT_TRUE(SameBits(a.risk.expected_shelter, b.risk.expected_shelter)) << where;
    EXPECT_TRUE(SameBits(a.risk.casualty_probability, b.risk.casualty_probability)) << where;
    EXPECT_TRUE(SameBits(a.risk.exposed_area_m2, b.risk.exposed_area_m2)) << where;
    EXPECT_EQ(a.risk.height_bin, b.risk.height_bin) << where;
    EXPECT_EQ(a.risk.heading_bin, b.risk.heading_bin) << where;
  }
}

// Random trajectories over the model's map: waypoints (Dubins manoeuvres) or
// polylines, at heights from below the terrain to above the ceiling, some
// running along or out past the map's edges.
struct Case {
  std::string name;
  std::vector<TrajectoryPiece> pieces;
};

std::vector<Case> Cases(const RiskModel& model, int count, uint64_t seed) {
  const RiskMap& m = model.map();
  const double w = m.nx() * m.res();
  const double h = m.ny() * m.res();
  Rng rng(seed);
  const auto ground = [&](double x, double y) {
    int i = 0, j = 0;
    return m.CellOf(x, y, &i, &j) ? static_cast<double>(m.terrain(i, j)) : 0.0;
  };
  std::vector<Case> out;
  for (int c = 0; c < count; ++c) {
    const int style = c % 4;
    const int points = 2 + static_cast<int>(rng.Uniform() * 4);
    std::vector<Pose> poses;
    for (int k = 0; k < points; ++k) {
      double x = 0.0;
      double y = 0.0;
      if (style == 0) {
        // Anywhere, a little past the edges too.
        x = m.x0() - 50.0 + rng.Uniform() * (w + 100.0);
        y = m.y0() - 50.0 + rng.Uniform() * (h + 100.0);
      } else if (style == 1) {
        // Along the border band, where windows reach past the map.
        const double band = rng.Uniform() * 400.0;
        const double along = rng.Uniform();
        switch (static_cast<int>(rng.Uniform() * 4)) {
          case 0: x = m.x0() + band, y = m.y0() + along * h; break;
          case 1: x = m.x0() + w - band, y = m.y0() + along * h; break;
          case 2: x = m.x0() + along * w, y = m.y0() + band; break;
          default: x = m.x0() + along * w, y = m.y0() + h - band; break;
        }
      } else {
        // Inside, clear of the border: mostly admissible.
        x = m.x0() + 500.0 + rng.Uniform() * (w - 1000.0);
        y = m.y0() + 500.0 + rng.Uniform() * (h - 1000.0);
      }
      // Heights above the ground: mostly in the flight band, sometimes
      // under the terrain or the safe altitude, or over the ceiling.
      const double r = rng.Uniform();
      const double agl = r < 0.05   ? -5.0
                         : r < 0.1  ? 10.0
                         : r < 0.15 ? model.params().max_agl_m + 30.0
                                    : 60.0 + rng.Uniform() * 150.0;
      poses.push_back({x, y, ground(x, y) + agl, rng.Uniform() * 6.283185307179586});
    }
    Case one;
    one.name = "case " + std::to_string(c) + " style " + std::to_string(style);
    if (c % 2 == 0) {
      auto pieces = PiecesFromWaypoints(poses, model.params());
      EXPECT_TRUE(pieces.ok()) << pieces.status();
      one.pieces = *pieces;
      one.name += " waypoints";
    } else {
      std::vector<Point3> points;
      for (const Pose& p : poses) points.push_back({p.x, p.y, p.z});
      auto pieces = PiecesFromPolyline(points);
      EXPECT_TRUE(pieces.ok()) << pieces.status();
      one.pieces = *pieces;
      one.name += " polyline";
    }
    out.push_back(std::move(one));
  }
  return out;
}

TEST(KernelEvaluatorTest, EvaluateTrajectoryThroughTheKernelIsTheCorePathBitForBit) {
  const RiskModel& model = *SmallCity();
  std::vector<Case> cases = Cases(model, 160, 14);
  // The straight flight of scripts/server-bench.sh's 100 m polyline and a
  // zero-length piece.
  cases.push_back({"short polyline", *PiecesFromPolyline(std::vector<Point3>{
                                         {1000, 1000, 250}, {1100, 1000, 250}})});
  cases.push_back({"zero-length piece", *PiecesFromPolyline(std::vector<Point3>{
                                            {1000, 1000, 250}, {1000, 1000, 250},
                                            {1050, 1000, 250}})});
  KernelRiskEvaluator portable(Isa::kPortable);
  KernelRiskEvaluator avx2(Isa::kAvx2);
  int inadmissible = 0;
  int outside_windows = 0;
  int admissible = 0;
  int undefined_samples = 0;
  for (const Case& c : cases) {
    for (bool keep : {false, true}) {
      const TrajectoryEvaluation want = Reference(model, c.pieces, keep);
      const std::string what = c.name + (keep ? " with samples" : "");
      auto core = EvaluateTrajectory(model, c.pieces, {.keep_samples = keep});
      ASSERT_TRUE(core.ok());
      ExpectSame(want, *core, what + ", core evaluator");
      for (RiskEvaluator* e : std::initializer_list<RiskEvaluator*>{
               &ThreadKernelEvaluator(), &portable, &avx2}) {
        auto fast = EvaluateTrajectory(model, c.pieces, {.keep_samples = keep}, e);
        ASSERT_TRUE(fast.ok());
        ExpectSame(want, *fast, what + ", kernel");
      }
      if (keep) {
        for (const SampleEvaluation& s : want.samples) undefined_samples += !s.risk.defined;
      }
    }
    const TrajectoryEvaluation want = Reference(model, c.pieces, false);
    admissible += want.admissible;
    inadmissible += !want.admissible;
    outside_windows += want.first_violation.has_value() &&
                       want.first_violation->kind == ViolationKind::kImpactOutsideMap;
  }
  // The cases cover what they are meant to.
  EXPECT_GE(admissible, 10);
  EXPECT_GE(inadmissible, 40);
  EXPECT_GE(outside_windows, 5);
  EXPECT_GE(undefined_samples, 100);
}

// The README's 7.5 km trajectory on the full demo-city, the one that
// scripts/server-bench.sh sends.
TEST(KernelEvaluatorTest, TheBenchmarkTrajectoryIsTheCorePathBitForBit) {
  static const std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    EXPECT_TRUE(map.ok());
    return *RiskModel::Create(*map, ModelParams{});
  }();
  const std::vector<Pose> waypoints = {
      {1200, 1500, 250, 0.785}, {4000, 4000, 250, 0.785}, {6800, 6500, 250, 0.785}};
  auto pieces = PiecesFromWaypoints(waypoints, model->params());
  ASSERT_TRUE(pieces.ok());
  for (bool keep : {false, true}) {
    auto fast = EvaluateTrajectory(*model, *pieces, {.keep_samples = keep},
                                   &ThreadKernelEvaluator());
    ASSERT_TRUE(fast.ok());
    ExpectSame(Reference(*model, *pieces, keep), *fast, "benchmark trajectory");
    EXPECT_EQ(fast->pieces[0].parts + fast->pieces[1].parts, 1502);
  }
}

// CheckConfiguration given M(q) is CheckConfiguration, on configurations of
// every kind (and with M from the kernel).
TEST(KernelEvaluatorTest, CheckConfigurationGivenTheRiskAgrees) {
  const RiskModel& model = *SmallCity();
  std::vector<Pose> configs = testing::MixedConfigs(model, 20000, 5);
  const RiskMap& m = model.map();
  Rng rng(6);
  for (int k = 0; k < 20000; ++k) {
    // Anywhere, and at heights of every rule.
    const double x = m.x0() - 30.0 + rng.Uniform() * (m.nx() * m.res() + 60.0);
    const double y = m.y0() - 30.0 + rng.Uniform() * (m.ny() * m.res() + 60.0);
    int i = 0, j = 0;
    const double t = m.CellOf(x, y, &i, &j) ? m.terrain(i, j) : 0.0;
    configs.push_back({x, y, t - 10.0 + rng.Uniform() * 400.0, rng.Uniform() * 7.0});
  }
  std::vector<ConfigurationRisk> risks(configs.size());
  ASSERT_TRUE(ThreadKernelEvaluator().EvaluateBatch(model, configs, risks).ok());
  int counts[7] = {};
  for (size_t n = 0; n < configs.size(); ++n) {
    double limit_a = 0.0;
    double limit_b = 0.0;
    const ViolationKind a = model.CheckConfiguration(configs[n], &limit_a);
    const ViolationKind b = model.CheckConfiguration(configs[n], risks[n], &limit_b);
    ASSERT_EQ(a, b) << n;
    ASSERT_TRUE(SameBits(limit_a, limit_b)) << n;
    ++counts[static_cast<int>(a)];
  }
  for (int kind = 0; kind < 7; ++kind) {
    EXPECT_GT(counts[kind], 0) << ViolationKindName(static_cast<ViolationKind>(kind));
  }
}

}  // namespace
}  // namespace riskplan::accel
