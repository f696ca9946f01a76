// FlightSession: the state of one in-flight session (proto Fly), as plain
// logic without gRPC: each input in, the outputs it makes out.
// docs/in-flight.md is the contract; here is how it is kept.
//
// The route is one list of waypoints from where the session began to the
// goal, joined by Dubins-airplane manoeuvres; its first `committed_` poses are
// the committed prefix, which only ever grows. The commit rule: after every
// accepted input the commit point lies at least H metres of route beyond
// the aircraft's progress, H = (commit horizon + replanning budget) x
// (airspeed + wind speed), the fastest the aircraft can cover ground; when it
// falls short it moves to progress + 1.5 H, splitting the manoeuvre there
// (the pose at that arc length becomes a waypoint). A plan version is made
// when the commit point moves, and at every change of the constraints
// (zones, wind, a position off the route); its remainder starts at the
// commit point, and its route (from the last waypoint at or behind the
// aircraft to the goal) is admissible under the risk model of that moment:
// the session's map with every active zone closed and its current wind
// (BuildModel: a no-fly layer of its own, the other layers shared, the glide
// layer repaired). Its risk, length and flight time are EvaluateTrajectory's.
//
// Replanning is "plan again from the commit point" with the request's
// planner and the replanning budget, keeping the current remainder (or one
// an earlier version had from the same commit point: a removed zone gives
// its route back) when it is admissible and no riskier. When neither is admissible the
// session sends an alert with the emergency landing from the commit point,
// and searching() stays true: Search() tries again (the call runs it while
// no input waits).
//
// Not thread-safe: one thread at a time (FlightCall serialises its inputs).
#ifndef RISKPLAN_SERVER_FLIGHT_FLIGHT_SESSION_H_
#define RISKPLAN_SERVER_FLIGHT_FLIGHT_SESSION_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/base/cancellation.h"
#include "core/flight/trajectory.h"
#include "core/planners/planner.h"
#include "riskplan/v1/planner.pb.h"
#include "server/api/request_validation.h"
#include "server/flight/flight_zones.h"
#include "server/flight/session_tree.h"
#include "server/models/map_registry.h"
#include "server/models/model_cache.h"

namespace riskplan::server {

// A session's bounds (set from the server's flags).
struct FlightLimits {
  ZoneLimits zones;
  double max_session_s = 86400.0;     // flight time from the opening to the last report
  double max_report_hz = 50.0;        // position reports per second of flight time (average)
  double report_burst = 10.0;         // reports allowed at once above that rate
  int64_t max_replan_time_ms = 10000; // FlightOpen.replan_budget.time_ms
  double max_commit_horizon_s = 600.0;
  size_t max_resume_poses = 1000;     // FlightOpen.committed
};

struct FlightEnv {
  const MapRegistry* maps = nullptr;
  RiskModelCache* models = nullptr;
  RequestLimits request_limits;
  FlightLimits limits;
};

class FlightSession {
 public:
  explicit FlightSession(const FlightEnv& env) : env_(env) {}

  // The first input must be `open`. An error here ends the session (the
  // status the stream finishes with, INVALID_ARGUMENT or NOT_FOUND naming the
  // field); every later input's error is a FlightRefusal among the outputs,
  // and the session goes on. `cancel` ends a plan early (the stream broke or
  // the server drains): the outputs made so far are returned.
  absl::StatusOr<std::vector<v1::FlightOutput>> Handle(const v1::FlightInput& input,
                                                       const CancellationToken& cancel);

  // Where outputs made before an input's handling ends go at once (the
  // FlightCall writes them): when set, a change's first admissible remainder
  // (the best already known, else the planner's first admissible solution)
  // is sent as soon as it exists, and the plan's final remainder follows as
  // an IMPROVED version when it is of less risk. Without one (the default)
  // each change makes one version, after the plan.
  void set_early_sink(std::function<void(v1::FlightOutput)> sink) {
    early_sink_ = std::move(sink);
  }

  // An alert is in force: Search() plans again from the commit point.
  bool searching() const { return searching_; }
  std::vector<v1::FlightOutput> Search(const CancellationToken& cancel);

  bool opened() const { return opened_; }
  bool ended() const { return ended_; }
  uint64_t versions() const { return version_; }
  const std::string& map_name() const { return spec_.map ? spec_.map->name() : empty_; }

  // For tests and benchmarks: the route and where it is committed.
  const std::vector<Pose>& route() const { return route_; }
  size_t committed_count() const { return committed_; }
  double progress_m() const { return progress_m_; }
  double commit_arc_m() const { return cum_[committed_ - 1]; }
  std::shared_ptr<const RiskModel> model() const { return model_; }
  // Wall time of the latest update of the model (zones or wind), ms.
  double model_update_ms() const { return model_update_ms_; }

 private:
  using Outputs = std::vector<v1::FlightOutput>;

  absl::StatusOr<Outputs> Open(const v1::FlightOpen& open, const StopCondition& stop);
  void OnPosition(const v1::PositionReport& report, const StopCondition& stop, Outputs* out);
  void OnAddZone(const v1::FlightZone& zone, const StopCondition& stop, Outputs* out);
  void OnRemoveZone(const v1::RemoveZone& remove, const StopCondition& stop, Outputs* out);
  void OnWind(const v1::WindChange& wind, const StopCondition& stop, Outputs* out);
  void Refuse(std::string field, std::string message, Outputs* out) const;

  // The zones active at now_s_, by id.
  std::vector<std::string> ActiveZoneIds() const;
  // model_ for params_ and the zones active now (base model from the cache).
  absl::Status BuildModel(const StopCondition& stop);
  // Recomputes cum_ from route_.
  absl::Status RecomputeArcs();
  // Moves the commit point to arc length `arc` (<= the route's length),
  // making the pose there a waypoint.
  absl::Status CommitTo(double arc);
  // True when the commit point is at least H ahead of the aircraft; else
  // moves it and returns false.
  bool CommitRuleHolds() const;
  // The route ends at the goal and all of it is committed.
  bool GoalCommitted() const;
  double HorizonM() const;
  // The waypoint index at or behind the aircraft.
  size_t AircraftWaypoint() const;
  Pose AircraftPose() const;
  absl::StatusOr<TrajectoryEvaluation> Evaluate(std::span<const Pose> waypoints,
                                                const StopCondition& stop) const;
  // Plans from `from` to the goal with `budget` under `limits`; nullopt (and
  // *why, with the limit filter's note) when no admissible trajectory was found.
  std::optional<std::vector<Pose>> PlanFrom(const Pose& from, const PlannerBudget& budget,
                                            const ::riskplan::FlightLimits& limits,
                                            const StopCondition& stop, std::string* why,
                                            const ImprovementCallback& on_improvement = {});
  // The opening request's flight limits apply to the whole mission (issue
  // 35): from the session's first pose to the goal. The committed prefix
  // (route_[0] ... the commit point): its exact numbers.
  absl::StatusOr<TrajectoryEvaluation> CommittedNumbers(const StopCondition& stop) const;
  // The limits a remainder from the commit point must meet: each mission
  // limit minus what the committed prefix uses (time, length, risk; the
  // per-hour target is checked on the whole mission by RemainderFits);
  // FailedPrecondition with the detail when the prefix leaves nothing.
  absl::StatusOr<::riskplan::FlightLimits> RemainderLimits(
      const TrajectoryEvaluation& committed) const;
  bool RemainderFits(const TrajectoryEvaluation& committed, const TrajectoryEvaluation& remainder,
                     const ::riskplan::FlightLimits& left) const;
  // Replans from the commit point and sends a version, or an alert.
  void Replan(v1::FlightReason reason, const StopCondition& stop, Outputs* out,
              const PlannerBudget& budget);
  // Makes `remainder` (from the commit point; the current one when
  // `is_current`) the route's, keeps the commit rule and sends a version;
  // false, with an alert, when it cannot.
  bool Adopt(const std::vector<Pose>& remainder, bool is_current, v1::FlightReason reason,
             Outputs* out);
  // A plan version of the current route (which must be admissible).
  absl::Status AddVersion(v1::FlightReason reason, Outputs* out);
  void AddAlert(v1::FlightAlertKind kind, std::string detail, Outputs* out);

  const FlightEnv env_;
  std::function<void(v1::FlightOutput)> early_sink_;
  const CancellationToken* cancel_ = nullptr;  // of the Handle or Search running
  const std::string empty_;
  bool opened_ = false;
  bool ended_ = false;
  bool resumed_ = false;
  bool searching_ = false;
  v1::FlightAlertKind last_alert_ = v1::FLIGHT_ALERT_UNSPECIFIED;
  uint64_t inputs_ = 0;
  uint64_t version_ = 0;
  absl::Time input_arrived_;

  PlanSpec spec_;
  ModelParams params_;
  double horizon_s_ = 10.0;
  PlannerBudget replan_budget_;
  SessionTree tree_;  // the goal tree every plan of the session queries
  std::shared_ptr<const RiskModel> model_;  // params_ and the active zones
  std::shared_ptr<const RiskModel> model_base_;  // the cache's model model_ derives from
  double model_update_ms_ = 0.0;
  std::shared_ptr<const std::vector<double>> glide_;  // of model_, made for alerts
  std::map<std::string, FlightZoneSpec> zones_;
  std::vector<std::string> active_ids_;

  std::vector<Pose> route_;
  // Remainders of earlier versions from the current commit point, still
  // candidates when the constraints change again (cleared when it moves).
  std::vector<std::vector<Pose>> alternatives_;
  std::vector<double> cum_;  // arc length at each waypoint
  size_t committed_ = 1;
  double progress_m_ = 0.0;
  double open_time_s_ = 0.0;
  double now_s_ = 0.0;
  std::optional<Pose> last_pose_;
  double report_tokens_ = 0.0;
  uint64_t searches_ = 0;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLIGHT_FLIGHT_SESSION_H_
