// `riskplan eval`: one EvaluateRisk call of a trajectory given by flags or
// a file, its risk piece by piece, and its ground-station and GIS files.
#include <cstdint>
#include <cstdio>
#include <string>

#include "absl/strings/str_format.h"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"
#include "client/cli/option_requests.h"

namespace riskplan::client {
namespace {

// One line for the two-tier result. A coarse-tier hit names a block of the
// coarse grid, not a map cell, so the word says which grid the indices are on.
std::string TwoTierText(const v1::TwoTierResult& t) {
  if (t.feasible()) {
    return absl::StrFormat("two-tier check: feasible (%d cells checked)",
                           static_cast<int64_t>(t.cells_checked()));
  }
  return absl::StrFormat(
      "two-tier check: NOT feasible: %s tier, %s in piece %d at (%.1f, %.1f, %.1f), %s %d, %d "
      "(%d cells checked)",
      v1::FeasibilityTier_Name(t.tier()), v1::ViolationKind_Name(t.kind()), t.segment(),
      t.position().x(), t.position().y(), t.position().z(),
      t.tier() == v1::COARSE ? "block" : "cell", t.cell_i(), t.cell_j(),
      static_cast<int64_t>(t.cells_checked()));
}

}  // namespace

int RunEval(const CliOptions& o, RiskplanClient& client) {
  absl::StatusOr<v1::EvaluateRiskRequest> request = EvalRequestFromOptions(o);
  if (!request.ok()) return Usage(std::string(request.status().message()));
  absl::StatusOr<ExportFiles> exports = ExportsFromOptions(o);
  if (!exports.ok()) return Usage(std::string(exports.status().message()));
  if (exports->any()) request->set_path_spacing_m(exports->spacing_m);
  v1::EvaluateRiskResponse r;
  grpc::Status status = client.EvaluateRisk(*request, &r, TimeoutOr(o, absl::Seconds(30)));
  if (!status.ok()) return RpcError(o, "EvaluateRisk", status);
  if (o.json) {
    std::printf("%s\n", ToJson(r).c_str());
    return exports->any() ? Export(*exports, r, o.map, "riskplan eval on " + o.map, /*quiet=*/true)
                          : 0;
  }
  // Risks with 9 significant digits: enough to tell apart the trajectories a
  // planner compares, and to check a plan's reported risk against an
  // evaluation of its waypoints; --json gives every digit.
  std::printf("risk %.9g expected casualties per flight, length %.1f m, %d samples, %s\n", r.risk(),
              r.length_m(), static_cast<int>(r.sample_count()),
              r.admissible() ? "admissible" : "NOT admissible");
  for (int i = 0; i < r.pieces_size(); ++i) {
    const v1::PieceEvaluation& p = r.pieces(i);
    std::printf("  piece %d: risk %.9g, length %.1f m, %d parts, %s\n", i, p.risk(), p.length_m(),
                p.parts(), p.admissible() ? "admissible" : "not admissible");
  }
  if (r.wind().speed_mps() > 0.0) std::printf("%s\n", WindText(r.wind()).c_str());
  std::printf("%s\n", TargetLevelOfSafetyText(r.risk_per_flight_hour(), r.flight_time_s(),
                                              r.airspeed_mps(), o.target_level_of_safety)
                          .c_str());
  if (r.has_first_violation()) {
    std::printf("first violation: %s\n", r.first_violation().message().c_str());
  }
  if (r.has_two_tier()) std::printf("%s\n", TwoTierText(r.two_tier()).c_str());
  if (o.samples) {
    // In wind two more columns: the air heading (where the aircraft points)
    // and the ground speed of each sample.
    const bool wind = r.wind().speed_mps() > 0.0;
    std::printf("%10s %10s %8s %6s %10s %5s %12s %12s %8s %8s%s\n", "x", "y", "z", "theta", "arc_m",
                "piece", "M", "I", "S", "p_cas", wind ? "    psi  gs_mps" : "");
    for (const v1::Sample& s : r.samples()) {
      std::printf("%10.1f %10.1f %8.1f %6.3f %10.1f %5d %12.5g %12.5g %8.3f %8.5f", s.x(), s.y(),
                  s.z(), s.theta(), s.arc_length_m(), s.piece(), s.risk(), s.impact_factor(),
                  s.expected_shelter(), s.casualty_probability());
      if (wind) std::printf(" %6.3f %7.2f", s.air_heading_rad(), s.ground_speed_mps());
      std::printf("\n");
    }
  }
  if (exports->any()) return Export(*exports, r, o.map, "riskplan eval on " + o.map);
  return 0;
}

}  // namespace riskplan::client
