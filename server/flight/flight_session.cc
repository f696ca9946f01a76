#include "server/flight/flight_session.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/flight/trajectory_piece.h"
#include "server/api/proto_convert.h"
#include "server/flight/emergency_landing.h"
#include "server/plan/plan_evaluator.h"

namespace riskplan::server {
namespace {

// A pose off the route by more than this (and 3 cells) is planned from.
constexpr double kOffRouteM = 60.0;
// Earlier remainders kept as candidates (from the same commit point).
constexpr size_t kMaxAlternatives = 8;
// Arc lengths this close are the same point.
constexpr double kArcEpsilonM = 1e-6;

void SetPose(const Pose& p, v1::Pose* out) { PoseToProto(p, out); }

}  // namespace

absl::StatusOr<std::vector<v1::FlightOutput>> FlightSession::Handle(
    const v1::FlightInput& input, const CancellationToken& cancel) {
  cancel_ = &cancel;
  const StopCondition stop(&cancel);
  ++inputs_;
  input_arrived_ = absl::Now();
  Outputs out;
  if (!opened_) {
    if (input.kind_case() != v1::FlightInput::kOpen) {
      return absl::InvalidArgumentError(
          "the first message of a Fly stream must be `open` (a FlightOpen)");
    }
    return Open(input.open(), stop);
  }
  if (ended_) {
    Refuse("kind", "the flight has ended; no input is taken after `end`", &out);
    return out;
  }
  switch (input.kind_case()) {
    case v1::FlightInput::kOpen:
      Refuse("open", "the session is already open; `open` is only the first message", &out);
      break;
    case v1::FlightInput::kPosition:
      OnPosition(input.position(), stop, &out);
      break;
    case v1::FlightInput::kAddZone:
      OnAddZone(input.add_zone(), stop, &out);
      break;
    case v1::FlightInput::kRemoveZone:
      OnRemoveZone(input.remove_zone(), stop, &out);
      break;
    case v1::FlightInput::kWind:
      OnWind(input.wind(), stop, &out);
      break;
    case v1::FlightInput::kEnd:
      ended_ = true;
      searching_ = false;
      break;
    default:
      Refuse("kind", "the input has no kind (open, position, add_zone, remove_zone, wind, end)",
             &out);
  }
  return out;
}

void FlightSession::Refuse(std::string field, std::string message, Outputs* out) const {
  v1::FlightRefusal* r = out->emplace_back().mutable_refusal();
  r->set_field(std::move(field));
  r->set_message(std::move(message));
  r->set_input(inputs_);
}

absl::StatusOr<std::vector<v1::FlightOutput>> FlightSession::Open(const v1::FlightOpen& open,
                                                                  const StopCondition& stop) {
  absl::StatusOr<PlanSpec> spec =
      ValidatePlanRequest(open.plan(), *env_.maps, env_.request_limits);
  if (!spec.ok()) {
    return absl::Status(spec.status().code(), absl::StrCat("open.plan.", spec.status().message()));
  }
  spec_ = *std::move(spec);
  params_ = spec_.params;
  const double horizon = open.commit_horizon_s();
  if (!std::isfinite(horizon) || (horizon != 0.0 && (horizon < 1.0 ||
                                                     horizon > env_.limits.max_commit_horizon_s))) {
    return absl::InvalidArgumentError(
        absl::StrFormat("open.commit_horizon_s has value %g; it must be 0 (10 s) or in [1, %g]",
                        horizon, env_.limits.max_commit_horizon_s));
  }
  horizon_s_ = horizon == 0.0 ? 10.0 : horizon;
  const v1::Budget& rb = open.replan_budget();
  if (rb.time_ms() < 0 || rb.time_ms() > env_.limits.max_replan_time_ms) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "open.replan_budget.time_ms has value %d; it must be in [0, %d] (--max_replan_time_ms)",
        rb.time_ms(), env_.limits.max_replan_time_ms));
  }
  if (rb.iterations() < 0 || rb.iterations() > env_.request_limits.max_iterations) {
    return absl::InvalidArgumentError(
        absl::StrFormat("open.replan_budget.iterations has value %d; it must be in [0, %d]",
                        rb.iterations(), env_.request_limits.max_iterations));
  }
  replan_budget_.max_time_s = rb.time_ms() / 1000.0;
  replan_budget_.max_iterations = rb.iterations();
  if (rb.time_ms() == 0 && rb.iterations() == 0) replan_budget_.max_time_s = 0.3;
  if (!std::isfinite(open.time_s()) || open.time_s() < 0.0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "open.time_s has value %g; it must be finite and >= 0", open.time_s()));
  }
  open_time_s_ = now_s_ = open.time_s();
  if (static_cast<size_t>(open.zones_size()) > env_.limits.zones.max_zones) {
    return absl::InvalidArgumentError(
        absl::StrFormat("open.zones has %d zones; a session holds at most %d (--max_flight_zones)",
                        open.zones_size(), env_.limits.zones.max_zones));
  }
  for (int k = 0; k < open.zones_size(); ++k) {
    absl::StatusOr<FlightZoneSpec> zone =
        ZoneFromProto(open.zones(k), env_.limits.zones, absl::StrCat("open.zones[", k, "]"));
    if (!zone.ok()) return zone.status();
    if (zones_.count(zone->id) != 0) {
      return absl::InvalidArgumentError(
          absl::StrFormat("open.zones[%d].id '%s' is already used by another zone", k, zone->id));
    }
    zones_.emplace(zone->id, *std::move(zone));
  }
  resumed_ = open.resume();
  if (!open.resume() &&
      (open.route_size() > 0 || open.committed_count() != 0 || open.progress_m() != 0.0)) {
    return absl::InvalidArgumentError(
        "open.route, open.committed_count and open.progress_m are for a resumed session "
        "(open.resume)");
  }
  if (static_cast<size_t>(open.route_size()) > env_.limits.max_resume_poses) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "open.route has %d poses; at most %d", open.route_size(), env_.limits.max_resume_poses));
  }
  route_.clear();
  for (int k = 0; k < open.route_size(); ++k) {
    absl::StatusOr<Pose> p = PoseFromProto(open.route(k), absl::StrCat("open.route[", k, "]"));
    if (!p.ok()) return p.status();
    if (absl::Status s = CheckInsideMap(*spec_.map, *p, absl::StrCat("open.route[", k, "]"));
        !s.ok()) {
      return s;
    }
    route_.push_back(*p);
  }
  size_t committed = 1;
  if (!route_.empty()) {
    const Pose& s = spec_.start;
    const Pose& c = route_.front();
    if (s.x != c.x || s.y != c.y || s.z != c.z) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "open.route[0] (%.1f, %.1f, %.1f) must be the start of open.plan (%.1f, %.1f, %.1f)",
          c.x, c.y, c.z, s.x, s.y, s.z));
    }
    route_.front() = s;  // the heading as the request normalised it
    if (open.committed_count() < 1 || open.committed_count() > route_.size()) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "open.committed_count has value %d; it must be in [1, %d], the poses of open.route",
          open.committed_count(), route_.size()));
    }
    committed = open.committed_count();
  } else {
    route_.push_back(spec_.start);
  }
  if (absl::Status s = BuildModel(stop); !s.ok()) return s;
  if (absl::Status s = CheckEndpoint(*model_, spec_.goal, "open.plan.goal"); !s.ok()) return s;
  if (absl::Status s = RecomputeArcs(); !s.ok()) return s;
  if (!std::isfinite(open.progress_m()) || open.progress_m() < 0.0 ||
      open.progress_m() > cum_.back()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "open.progress_m has value %g; it must be in [0, %g], the length of open.route",
        open.progress_m(), cum_.back()));
  }
  progress_m_ = open.progress_m();
  committed_ = committed;
  opened_ = true;
  report_tokens_ = env_.limits.report_burst;
  Outputs out;
  // The aircraft flew on along the route while the link was down: the
  // commit point follows it there first (as the broken session would have).
  if (route_.size() >= 2 && !CommitRuleHolds()) {
    if (absl::Status s = CommitTo(progress_m_ + 1.5 * HorizonM()); !s.ok()) return s;
  }
  // The first plan: from the end of what is committed, with the request's
  // budget; a resumed session's with the replanning budget (the aircraft flies).
  PlannerBudget first = resumed_ ? replan_budget_ : spec_.options.budget;
  Replan(v1::FLIGHT_REASON_OPENED, stop, &out, first);
  return out;
}

std::vector<std::string> FlightSession::ActiveZoneIds() const {
  std::vector<std::string> ids;
  for (const auto& [id, zone] : zones_) {
    if (zone.ActiveAt(now_s_)) ids.push_back(id);
  }
  return ids;
}

absl::Status FlightSession::BuildModel(const StopCondition& stop) {
  const absl::Time started = absl::Now();
  absl::StatusOr<std::shared_ptr<const RiskModel>> base = env_.models->Get(*spec_.map, params_);
  if (!base.ok()) return base.status();
  active_ids_ = ActiveZoneIds();
  std::vector<const FlightZoneSpec*> active;
  for (const std::string& id : active_ids_) active.push_back(&zones_.at(id));
  glide_.reset();
  int64_t closed = 0;
  std::vector<uint8_t> nofly = NoFlyWithZones((*base)->map(), active, &closed);
  if (closed == 0) {
    model_ = *base;
  } else {
    // No map is copied: the model of the moment shares the base model's
    // layers and table and has a no-fly layer of its own, and its glide
    // layers are repaired from the model it follows (the zones that came or
    // went since), or from the base one after a wind change.
    const RiskModel& from = model_ != nullptr && model_base_ == *base ? *model_ : **base;
    absl::StatusOr<std::shared_ptr<const RiskMap>> map =
        RiskMap::WithNoFly(from.map_ptr(), std::move(nofly), stop);
    if (!map.ok()) return map.status();
    absl::StatusOr<std::shared_ptr<const RiskModel>> model =
        RiskModel::WithMap(from, *std::move(map), stop);
    if (!model.ok()) return model.status();
    model_ = *std::move(model);
  }
  model_base_ = *base;
  model_update_ms_ = absl::ToDoubleMilliseconds(absl::Now() - started);
  return absl::OkStatus();
}

absl::Status FlightSession::RecomputeArcs() {
  cum_.assign(route_.size(), 0.0);
  if (route_.size() < 2) return absl::OkStatus();
  absl::StatusOr<std::vector<TrajectoryPiece>> pieces = PiecesFromWaypoints(route_, params_);
  if (!pieces.ok()) return pieces.status();
  for (size_t k = 0; k < pieces->size(); ++k) cum_[k + 1] = cum_[k] + (*pieces)[k].Length();
  return absl::OkStatus();
}

double FlightSession::HorizonM() const {
  const double budget_s = replan_budget_.max_time_s > 0.0 ? replan_budget_.max_time_s : 1.0;
  return (horizon_s_ + budget_s) * (params_.airspeed_mps + params_.wind_speed_mps);
}

bool FlightSession::GoalCommitted() const {
  const Pose& last = route_.back();
  return route_.size() >= 2 && committed_ == route_.size() && last.x == spec_.goal.x &&
         last.y == spec_.goal.y && last.z == spec_.goal.z;
}

bool FlightSession::CommitRuleHolds() const {
  return GoalCommitted() || cum_[committed_ - 1] >= progress_m_ + HorizonM();
}

absl::Status FlightSession::CommitTo(double arc) {
  arc = std::min(arc, cum_.back());
  const size_t before = committed_;
  while (committed_ < route_.size() && cum_[committed_] <= arc + kArcEpsilonM) ++committed_;
  if (committed_ != before) alternatives_.clear();
  if (committed_ == route_.size() || cum_[committed_ - 1] >= arc - kArcEpsilonM) {
    return absl::OkStatus();
  }
  // Split the manoeuvre from route_[committed_ - 1] at `arc`.
  const size_t k = committed_ - 1;
  const TrajectoryPiece piece = TrajectoryPiece::Manoeuvre(
      route_[k], route_[k + 1], params_.GroundTurnRadius(), params_.GroundClimbAngle());
  const Pose split = piece.PoseAt(arc - cum_[k]);
  alternatives_.clear();
  route_.insert(route_.begin() + static_cast<std::ptrdiff_t>(k + 1), split);
  ++committed_;
  return RecomputeArcs();
}

size_t FlightSession::AircraftWaypoint() const {
  size_t k = 0;
  while (k + 1 < committed_ && cum_[k + 1] <= progress_m_) ++k;
  return k;
}

Pose FlightSession::AircraftPose() const {
  const size_t k = AircraftWaypoint();
  if (k + 1 >= route_.size()) return route_[k];
  const TrajectoryPiece piece = TrajectoryPiece::Manoeuvre(
      route_[k], route_[k + 1], params_.GroundTurnRadius(), params_.GroundClimbAngle());
  return piece.PoseAt(progress_m_ - cum_[k]);
}

absl::StatusOr<TrajectoryEvaluation> FlightSession::Evaluate(std::span<const Pose> waypoints,
                                                             const StopCondition& stop) const {
  absl::StatusOr<std::vector<TrajectoryPiece>> pieces = PiecesFromWaypoints(waypoints, params_);
  if (!pieces.ok()) return pieces.status();
  return EvaluateTrajectory(*model_, *pieces, {}, nullptr, stop);
}

absl::StatusOr<TrajectoryEvaluation> FlightSession::CommittedNumbers(
    const StopCondition& stop) const {
  if (committed_ < 2) return TrajectoryEvaluation{};
  return Evaluate(std::span<const Pose>(route_.data(), committed_), stop);
}

absl::StatusOr<::riskplan::FlightLimits> FlightSession::RemainderLimits(
    const TrajectoryEvaluation& committed) const {
  ::riskplan::FlightLimits left = spec_.options.limits;
  left.max_risk_per_flight_hour = 0.0;  // of the whole mission: RemainderFits
  std::vector<std::string> spent;
  const auto take = [&](const char* name, double limit, double used, const char* unit,
                        double* out) {
    if (limit <= 0.0) return;
    *out = limit - used;
    if (!(*out > 0.0)) {
      spent.push_back(absl::StrFormat(
          "the committed route (from the session's first pose to the commit point) already "
          "uses %.6g%s of %s = %g%s",
          used, unit, name, limit, unit));
    }
  };
  take("max_flight_time_s", spec_.options.limits.max_flight_time_s, committed.flight_time_s,
       " s", &left.max_flight_time_s);
  take("max_length_m", spec_.options.limits.max_length_m, committed.length_m, " m",
       &left.max_length_m);
  take("max_risk", spec_.options.limits.max_risk, committed.risk, "", &left.max_risk);
  if (!spent.empty()) {
    return absl::FailedPreconditionError(
        absl::StrCat("no remainder can meet the mission's flight limits: ",
                     absl::StrJoin(spent, "; ")));
  }
  return left;
}

bool FlightSession::RemainderFits(const TrajectoryEvaluation& committed,
                                  const TrajectoryEvaluation& remainder,
                                  const ::riskplan::FlightLimits& left) const {
  if (!CheckNumbers(remainder.risk, remainder.length_m, remainder.flight_time_s, left).meets) {
    return false;
  }
  const double hour = spec_.options.limits.max_risk_per_flight_hour;
  return hour <= 0.0 || RiskPerFlightHour(committed.risk + remainder.risk,
                                          committed.flight_time_s + remainder.flight_time_s) <=
                            hour;
}

std::optional<std::vector<Pose>> FlightSession::PlanFrom(const Pose& from,
                                                         const PlannerBudget& budget,
                                                         const ::riskplan::FlightLimits& limits,
                                                         const StopCondition& /*stop*/,
                                                         std::string* why,
                                                         const ImprovementCallback& on_improvement) {
  if (absl::Status s = CheckEndpoint(*model_, from, "commit point"); !s.ok()) {
    *why = std::string(s.message());
    return std::nullopt;
  }
  if (absl::Status s = CheckEndpoint(*model_, spec_.goal, "goal"); !s.ok()) {
    *why = std::string(s.message());
    return std::nullopt;
  }
  PlanOptions options = spec_.options;
  options.budget = budget;
  options.limits = limits;
  options.record_tree = false;
  // A seed of its own for every plan of the session, reproducible.
  options.seed = spec_.options.seed + version_ * 7919 + searches_;
  // The session's cancellation (a broken stream, the drain) stops the planner.
  static const CancellationToken kNever;
  const CancellationToken& cancel = cancel_ != nullptr ? *cancel_ : kNever;
  // Risks by accel's exact kernel on this thread (the planner's own risks bit
  // for bit, faster); the plan a query into the session's kept goal tree
  // (SessionTree: RISK_RRT_STAR without binding limits), else a plan from
  // the goal.
  std::unique_ptr<RiskEvaluator> evaluator =
      NewPlanEvaluator(nullptr, options, StopCondition(&cancel));
  absl::StatusOr<PlanResult> result =
      tree_.Plan(model_, spec_.algorithm, from, spec_.goal, options, evaluator.get(), cancel,
                 [&](const PlanImprovement& imp) {
                   if (on_improvement) on_improvement(imp);
                 });
  if (!result.ok()) {
    *why = std::string(result.status().message());
    return std::nullopt;
  }
  if (!result->best.has_value()) {
    *why = absl::StrFormat("the planner found no admissible remainder in its budget (%s)",
                           StopReasonName(result->reason));
    if (!result->limits.note.empty()) absl::StrAppend(why, ": ", result->limits.note);
    return std::nullopt;
  }
  return result->best->waypoints;
}

void FlightSession::Replan(v1::FlightReason reason, const StopCondition& stop, Outputs* out,
                           const PlannerBudget& budget) {
  const size_t k = AircraftWaypoint();
  // The aircraft itself, then the committed part ahead of it: what no plan can change.
  const Pose aircraft = AircraftPose();
  for (const std::string& id : active_ids_) {
    if (zones_.at(id).Contains(aircraft)) {
      searching_ = true;
      AddAlert(v1::FLIGHT_ALERT_INSIDE_ZONE,
               absl::StrFormat("the aircraft at (%.1f, %.1f, %.1f) is inside zone '%s'", aircraft.x,
                               aircraft.y, aircraft.z, id),
               out);
      return;
    }
  }
  if (committed_ - k >= 2) {
    std::span<const Pose> prefix(route_.data() + k, committed_ - k);
    absl::StatusOr<TrajectoryEvaluation> e = Evaluate(prefix, stop);
    if (e.ok() && !e->admissible) {
      searching_ = true;
      AddAlert(v1::FLIGHT_ALERT_INSIDE_ZONE,
               absl::StrCat("the committed prefix ahead of the aircraft is not admissible now: ",
                            e->first_violation ? e->first_violation->ToString() : ""),
               out);
      return;
    }
  }
  const Pose commit = route_[committed_ - 1];
  if (GoalCommitted()) {
    // The goal is committed: nothing is left to plan.
    searching_ = false;
    if (absl::Status s = AddVersion(reason, out); !s.ok()) AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::string(s.message()), out);
    return;
  }
  // The mission's flight limits: what the committed prefix leaves of them.
  absl::StatusOr<TrajectoryEvaluation> committed_numbers = CommittedNumbers(stop);
  if (!committed_numbers.ok()) {
    searching_ = true;
    AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::string(committed_numbers.status().message()),
             out);
    return;
  }
  absl::StatusOr<::riskplan::FlightLimits> left = RemainderLimits(*committed_numbers);
  if (!left.ok()) {
    searching_ = true;
    AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::string(left.status().message()), out);
    return;
  }
  const bool min_time = left->objective == PlanObjective::kMinTime;
  // The candidates: the current remainder, and the remainders of earlier
  // versions from this same commit point (so that a removed zone gives its
  // route back), then a new plan from the commit point; each must fit what
  // the limits leave, and the best by the objective (least risk, or least
  // flight time) wins.
  const std::vector<Pose> current(route_.begin() + static_cast<std::ptrdiff_t>(committed_ - 1),
                                  route_.end());
  std::vector<std::vector<Pose>> candidates;
  for (const std::vector<Pose>& a : alternatives_) {
    if (a.front().x == commit.x && a.front().y == commit.y && a.front().z == commit.z &&
        a.front().theta == commit.theta) {
      candidates.push_back(a);
    }
  }
  candidates.push_back(current);
  const size_t current_index = candidates.size() - 1;
  // The objective's value of a candidate (risk, or flight time).
  const auto value = [&](const TrajectoryEvaluation& e) {
    return min_time ? e.flight_time_s : e.risk;
  };
  std::optional<double> best_risk;
  size_t best = 0;
  size_t unfit = 0;
  for (size_t c = 0; c < candidates.size(); ++c) {
    if (candidates[c].size() < 2) continue;
    absl::StatusOr<TrajectoryEvaluation> e = Evaluate(candidates[c], stop);
    if (!e.ok() || !e->admissible) continue;
    if (!RemainderFits(*committed_numbers, *e, *left)) {
      ++unfit;
      continue;
    }
    // Ties keep the later candidate (the current remainder is last).
    if (!best_risk.has_value() || value(*e) <= *best_risk) {
      best_risk = value(*e);
      best = c;
    }
  }
  // With an early sink (the call's), the first admissible remainder that fits
  // the limits goes out at once: the best candidate known now, else the
  // planner's first such solution; the plan's final one follows as an
  // IMPROVED version when it is better by the objective, from the same
  // commit point. (sent_risk holds the objective's value: risk, or time.)
  const bool early = early_sink_ != nullptr && reason != v1::FLIGHT_REASON_OPENED;
  const size_t committed_before = committed_;
  std::optional<double> sent_risk;
  const auto send_early = [&](const std::vector<Pose>& remainder, bool is_current, double risk) {
    Outputs now;
    if (Adopt(remainder, is_current, reason, &now)) sent_risk = risk;
    for (v1::FlightOutput& o : now) early_sink_(std::move(o));
  };
  if (early && best_risk.has_value()) send_early(candidates[best], best == current_index, *best_risk);
  ImprovementCallback on_improvement;
  if (early && !sent_risk.has_value()) {
    on_improvement = [&](const PlanImprovement& imp) {
      if (sent_risk.has_value() || committed_ != committed_before) return;
      absl::StatusOr<TrajectoryEvaluation> e = Evaluate(imp.waypoints, stop);
      if (e.ok() && e->admissible && RemainderFits(*committed_numbers, *e, *left)) {
        send_early(imp.waypoints, false, value(*e));
      }
    };
  }
  std::string why;
  std::optional<std::vector<Pose>> fresh =
      PlanFrom(commit, budget, *left, stop, &why, on_improvement);
  if (sent_risk.has_value()) {
    // A version is out. The plan's remainder replaces it only from the same
    // commit point (the version may have moved it on), within what the
    // limits leave, and better by the objective.
    if (!fresh.has_value() || committed_ != committed_before) return;
    absl::StatusOr<TrajectoryEvaluation> e = Evaluate(*fresh, stop);
    if (e.ok() && e->admissible && RemainderFits(*committed_numbers, *e, *left) &&
        value(*e) < *sent_risk) {
      Adopt(*fresh, false, v1::FLIGHT_REASON_IMPROVED, out);
    }
    return;
  }
  if (fresh.has_value()) {
    absl::StatusOr<TrajectoryEvaluation> e = Evaluate(*fresh, stop);
    if (e.ok() && e->admissible && RemainderFits(*committed_numbers, *e, *left)) {
      if (!best_risk.has_value() || value(*e) < *best_risk) {
        candidates.push_back(*std::move(fresh));
        best_risk = value(*e);
        best = candidates.size() - 1;
      }
    } else if (e.ok() && e->admissible) {
      ++unfit;
      why = "the planner's remainder does not meet the mission's flight limits";
    } else {
      why = "the planner's remainder is not admissible under the session's zones";
    }
  }
  if (!best_risk.has_value()) {
    searching_ = true;
    std::string detail = absl::StrCat("no admissible remainder from the commit point yet: ", why);
    if (spec_.options.limits.Active() && committed_numbers->length_m > 0.0) {
      absl::StrAppend(&detail,
                      absl::StrFormat(" (the committed route flies %.1f s, %.1f m, risk %.4g "
                                      "of the mission's limits; %d admissible remainders did "
                                      "not fit what is left)",
                                      committed_numbers->flight_time_s,
                                      committed_numbers->length_m, committed_numbers->risk, unfit));
    }
    AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::move(detail), out);
    return;
  }
  Adopt(candidates[best], best == current_index, reason, out);
}

bool FlightSession::Adopt(const std::vector<Pose>& remainder, bool is_current,
                          v1::FlightReason reason, Outputs* out) {
  if (!is_current) {
    // The remainder it replaces stays a candidate for later changes.
    const std::vector<Pose> current(route_.begin() + static_cast<std::ptrdiff_t>(committed_ - 1),
                                    route_.end());
    if (current.size() >= 2) {
      alternatives_.push_back(current);
      if (alternatives_.size() > kMaxAlternatives) alternatives_.erase(alternatives_.begin());
    }
    route_.resize(committed_);
    route_.insert(route_.end(), remainder.begin() + 1, remainder.end());
  }
  if (absl::Status s = RecomputeArcs(); !s.ok()) {
    searching_ = true;
    AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::string(s.message()), out);
    return false;
  }
  if (!CommitRuleHolds()) {
    if (absl::Status s = CommitTo(progress_m_ + 1.5 * HorizonM()); !s.ok()) {
      searching_ = true;
      AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::string(s.message()), out);
      return false;
    }
  }
  if (absl::Status s = AddVersion(reason, out); !s.ok()) {
    searching_ = true;
    AddAlert(v1::FLIGHT_ALERT_NO_REMAINDER, std::string(s.message()), out);
    return false;
  }
  searching_ = false;
  last_alert_ = v1::FLIGHT_ALERT_UNSPECIFIED;
  return true;
}

absl::Status FlightSession::AddVersion(v1::FlightReason reason, Outputs* out) {
  const size_t k = AircraftWaypoint();
  std::span<const Pose> route(route_.data() + k, route_.size() - k);
  std::span<const Pose> remainder(route_.data() + committed_ - 1, route_.size() - committed_ + 1);
  v1::FlightOutput output;
  v1::FlightPlanVersion* v = output.mutable_plan();
  const auto fill = [&](std::span<const Pose> poses, v1::Trajectory* t,
                        bool margins) -> absl::Status {
    if (poses.size() < 2) {
      for (const Pose& p : poses) SetPose(p, t->add_waypoints());
      return absl::OkStatus();
    }
    absl::StatusOr<std::vector<TrajectoryPiece>> pieces = PiecesFromWaypoints(poses, params_);
    if (!pieces.ok()) return pieces.status();
    absl::StatusOr<TrajectoryEvaluation> e = EvaluateTrajectory(*model_, *pieces);
    if (!e.ok()) return e.status();
    if (!e->admissible) {
      return absl::InternalError(absl::StrCat(
          "a plan version's route is not admissible (a bug): ",
          e->first_violation ? e->first_violation->ToString() : ""));
    }
    PlanImprovement imp;
    imp.waypoints.assign(poses.begin(), poses.end());
    imp.risk = e->risk;
    imp.length_m = e->length_m;
    if (absl::Status s = TrajectoryToProto(imp, params_, spec_.display_step_m, spec_.frame.get(), t);
        !s.ok()) {
      return s;
    }
    t->set_flight_time_s(e->flight_time_s);
    t->set_risk_per_flight_hour(RiskPerFlightHour(e->risk, e->flight_time_s));
    if (margins) {
      const RiskMap& map = model_->map();
      double min_agl = std::numeric_limits<double>::infinity();
      double max_agl = -std::numeric_limits<double>::infinity();
      double safe = std::numeric_limits<double>::infinity();
      for (const PathPose& p : SamplePath(*pieces, std::max(1.0, map.res()), 100000)) {
        int i = 0, j = 0;
        if (!map.CellOf(p.pose.x, p.pose.y, &i, &j)) continue;
        const double agl = p.pose.z - map.terrain(i, j);
        min_agl = std::min(min_agl, agl);
        max_agl = std::max(max_agl, agl);
        safe = std::min(safe, p.pose.z - model_->SafeAltitude(i, j));
      }
      const auto margin = [&](const char* name, double value, double bound, double m) {
        v1::FlightMargin* f = v->add_margins();
        f->set_limit(name);
        f->set_value(value);
        f->set_bound(bound);
        f->set_margin(m);
      };
      margin("min_agl_m", min_agl, params_.min_agl_m, min_agl - params_.min_agl_m);
      margin("max_agl_m", max_agl, params_.max_agl_m, params_.max_agl_m - max_agl);
      margin("safe_altitude_m", safe, 0.0, safe);
    }
    return absl::OkStatus();
  };
  if (absl::Status s = fill(route, v->mutable_route(), true); !s.ok()) return s;
  if (absl::Status s = fill(remainder, v->mutable_remainder(), false); !s.ok()) return s;
  // The mission's numbers (issue 35): the committed prefix from the
  // session's first pose, and with flight limits the whole mission (that
  // prefix, then the remainder) against each limit.
  absl::StatusOr<TrajectoryEvaluation> committed = CommittedNumbers(StopCondition());
  if (!committed.ok()) return committed.status();
  v->set_committed_flight_time_s(committed->flight_time_s);
  v->set_committed_length_m(committed->length_m);
  v->set_committed_risk(committed->risk);
  const ::riskplan::FlightLimits& limits = spec_.options.limits;
  if (limits.max_flight_time_s > 0.0 || limits.max_length_m > 0.0 || limits.max_risk > 0.0 ||
      limits.max_risk_per_flight_hour > 0.0) {
    absl::StatusOr<TrajectoryEvaluation> mission =
        route_.size() >= 2 ? Evaluate(route_, StopCondition())
                           : absl::StatusOr<TrajectoryEvaluation>(TrajectoryEvaluation{});
    if (!mission.ok()) return mission.status();
    const auto margin = [&](const char* name, double value, double bound) {
      if (bound <= 0.0) return;
      v1::FlightMargin* f = v->add_margins();
      f->set_limit(name);
      f->set_value(value);
      f->set_bound(bound);
      f->set_margin(bound - value);
    };
    margin("max_flight_time_s", mission->flight_time_s, limits.max_flight_time_s);
    margin("max_length_m", mission->length_m, limits.max_length_m);
    margin("max_risk", mission->risk, limits.max_risk);
    margin("max_risk_per_flight_hour", RiskPerFlightHour(mission->risk, mission->flight_time_s),
           limits.max_risk_per_flight_hour);
  }
  v->set_version(++version_);
  v->set_reason(reason);
  for (size_t i = 0; i < committed_; ++i) SetPose(route_[i], v->add_committed());
  v->set_committed_until_m(cum_[committed_ - 1]);
  v->set_progress_m(progress_m_);
  for (const std::string& id : active_ids_) v->add_active_zones(id);
  v->set_time_s(now_s_);
  v->set_resumed(resumed_);
  v->set_planning_ms(absl::ToDoubleMilliseconds(absl::Now() - input_arrived_));
  out->push_back(std::move(output));
  return absl::OkStatus();
}

void FlightSession::AddAlert(v1::FlightAlertKind kind, std::string detail, Outputs* out) {
  last_alert_ = kind;
  v1::FlightAlert* a = out->emplace_back().mutable_alert();
  a->set_kind(kind);
  const Pose commit = route_[committed_ - 1];
  SetPose(commit, a->mutable_commit_point());
  for (const std::string& id : active_ids_) a->add_active_zones(id);
  a->set_time_s(now_s_);
  a->set_last_version(version_);
  // The glide layer of the moment (zones closed), except that the zones
  // around the commit point stay open: an aircraft in a zone may glide out
  // of it. Landing sites in closed cells are not landed on.
  std::optional<EmergencyOption> landing;
  const RiskMap& map = model_->map();
  int ci = 0, cj = 0;
  if (map.CellOf(commit.x, commit.y, &ci, &cj)) {
    const double cx = map.x0() + (ci + 0.5) * map.res();
    const double cy = map.y0() + (cj + 0.5) * map.res();
    const double reach = 0.5 * map.res() * std::numbers::sqrt2;
    std::vector<const FlightZoneSpec*> closed;
    bool around = false;
    for (const std::string& id : active_ids_) {
      const FlightZoneSpec& zone = zones_.at(id);
      if (zone.DistanceXY(cx, cy) <= reach) {
        around = true;
      } else {
        closed.push_back(&zone);
      }
    }
    std::shared_ptr<const std::vector<double>> glide;
    if (!around) {
      if (glide_ == nullptr) {
        absl::StatusOr<std::shared_ptr<const std::vector<double>>> g =
            GlideLayerOf(*model_, StopCondition());
        if (g.ok()) glide_ = *g;
      }
      glide = glide_;
    } else {
      absl::StatusOr<std::shared_ptr<const std::vector<double>>> g = GlideLayerRepaired(
          *model_, NoFlyWithZones(*spec_.map, closed), StopCondition());
      if (g.ok()) glide = *g;
    }
    if (glide != nullptr) landing = FindEmergencyLanding(map, params_, *glide, commit);
  }
  if (landing.has_value()) {
    v1::EmergencyLanding* l = a->mutable_landing();
    l->set_site(landing->site);
    SetPose(landing->site_pose, l->mutable_site_pose());
    for (const Pose& p : landing->glide) SetPose(p, l->add_glide());
    SetPose(commit, l->mutable_from());
    l->set_glide_distance_m(landing->glide_distance_m);
    l->set_altitude_margin_m(landing->altitude_margin_m);
  } else {
    absl::StrAppend(&detail, "; no landing site can be reached by glide from the commit point");
  }
  a->set_detail(std::move(detail));
}

void FlightSession::OnPosition(const v1::PositionReport& report, const StopCondition& stop,
                               Outputs* out) {
  const double t = report.time_s();
  if (!std::isfinite(t)) {
    Refuse("position.time_s", absl::StrFormat("position.time_s has value %g; it must be finite", t),
           out);
    return;
  }
  if (t < now_s_) {
    Refuse("position.time_s",
           absl::StrFormat("position.time_s %.3f runs backwards: the latest time is %.3f", t,
                           now_s_),
           out);
    return;
  }
  if (t - open_time_s_ > env_.limits.max_session_s) {
    Refuse("position.time_s",
           absl::StrFormat("position.time_s %.3f is %.0f s after the opening; a session lasts at "
                           "most %.0f s of flight",
                           t, t - open_time_s_, env_.limits.max_session_s),
           out);
    return;
  }
  const double dt = t - now_s_;
  const double tokens =
      std::min(env_.limits.report_burst, report_tokens_ + dt * env_.limits.max_report_hz);
  if (tokens < 1.0) {
    Refuse("position",
           absl::StrFormat("more than %g position reports per second of flight time "
                           "(--max_flight_report_hz; bursts of %g)",
                           env_.limits.max_report_hz, env_.limits.report_burst),
           out);
    return;
  }
  // The farthest the aircraft can have flown since the last report.
  const double reach =
      (params_.airspeed_mps + params_.wind_speed_mps) * dt * 1.25 + spec_.map->res();
  const double route_length = cum_.back();
  double progress = progress_m_;
  bool off_route = false;
  Pose pose;
  if (report.where_case() == v1::PositionReport::kProgressM) {
    progress = report.progress_m();
    if (!std::isfinite(progress) || progress < progress_m_ || progress > route_length) {
      Refuse("position.progress_m",
             absl::StrFormat("position.progress_m has value %g; it must be in [%g, %g] (the "
                             "latest progress and the route's length)",
                             progress, progress_m_, route_length),
             out);
      return;
    }
    if (progress - progress_m_ > reach) {
      Refuse("position.progress_m",
             absl::StrFormat("position.progress_m moves %.1f m in %.3f s: faster than the aircraft "
                             "can fly (at most %.1f m)",
                             progress - progress_m_, dt, reach),
             out);
      return;
    }
  } else if (report.where_case() == v1::PositionReport::kPose) {
    absl::StatusOr<Pose> p = PoseFromProto(report.pose(), "position.pose");
    if (!p.ok()) {
      Refuse("position.pose", std::string(p.status().message()), out);
      return;
    }
    if (absl::Status s = CheckInsideMap(*spec_.map, *p, "position.pose"); !s.ok()) {
      Refuse("position.pose", std::string(s.message()), out);
      return;
    }
    pose = *p;
    const Pose from = last_pose_.value_or(AircraftPose());
    const double moved = std::hypot(pose.x - from.x, pose.y - from.y);
    if (moved > reach) {
      Refuse("position.pose",
             absl::StrFormat("position.pose moves %.1f m in %.3f s: faster than the aircraft can "
                             "fly (at most %.1f m)",
                             moved, dt, reach),
             out);
      return;
    }
    // Project onto the route ahead of the latest progress, within reach.
    absl::StatusOr<std::vector<TrajectoryPiece>> pieces =
        route_.size() >= 2 ? PiecesFromWaypoints(route_, params_)
                           : absl::StatusOr<std::vector<TrajectoryPiece>>(std::vector<TrajectoryPiece>{});
    double best = std::numeric_limits<double>::infinity();
    if (pieces.ok()) {
      for (size_t k = 0; k + 1 < route_.size(); ++k) {
        if (cum_[k + 1] < progress_m_ || cum_[k] > progress_m_ + reach) continue;
        const TrajectoryPiece& piece = (*pieces)[k];
        const double step = std::max(1.0, spec_.map->res() / 2.0);
        for (double s = std::max(0.0, progress_m_ - cum_[k]); s <= piece.Length() + step; s += step) {
          const double ss = std::min(s, piece.Length());
          if (cum_[k] + ss > progress_m_ + reach) break;
          const Pose q = piece.PoseAt(ss);
          const double d = std::hypot(q.x - pose.x, q.y - pose.y);
          if (d < best) {
            best = d;
            progress = cum_[k] + ss;
          }
          if (ss == piece.Length()) break;
        }
      }
    }
    off_route = best > std::max(kOffRouteM, 3.0 * spec_.map->res());
  } else {
    Refuse("position", "a position report needs a pose or progress_m", out);
    return;
  }
  // Accepted.
  report_tokens_ = tokens - 1.0;
  now_s_ = t;
  if (report.where_case() == v1::PositionReport::kPose) last_pose_ = pose;
  const std::vector<std::string> was_active = active_ids_;
  const bool zones_changed = ActiveZoneIds() != was_active;
  if (off_route) {
    // Planned from where the aircraft is: the committed prefix starts again there.
    route_.assign(1, pose);
    alternatives_.clear();
    committed_ = 1;
    progress_m_ = 0.0;
    cum_.assign(1, 0.0);
    if (zones_changed) {
      if (absl::Status s = BuildModel(stop); !s.ok()) {
        Refuse("position", std::string(s.message()), out);
        return;
      }
    }
    Replan(v1::FLIGHT_REASON_OFF_ROUTE, stop, out, replan_budget_);
    return;
  }
  progress_m_ = std::max(progress_m_, progress);
  if (zones_changed) {
    if (absl::Status s = BuildModel(stop); !s.ok()) {
      Refuse("position", std::string(s.message()), out);
      return;
    }
    Replan(v1::FLIGHT_REASON_ZONE_TIMED, stop, out, replan_budget_);
    return;
  }
  if (CommitRuleHolds()) return;
  if (absl::Status s = CommitTo(progress_m_ + 1.5 * HorizonM()); !s.ok()) {
    Refuse("position", std::string(s.message()), out);
    return;
  }
  if (searching_) {
    Replan(v1::FLIGHT_REASON_SEARCH, stop, out, replan_budget_);
    return;
  }
  if (absl::Status s = AddVersion(v1::FLIGHT_REASON_PROGRESS, out); !s.ok()) {
    // The split made the remainder inadmissible (it never should): plan again.
    Replan(v1::FLIGHT_REASON_PROGRESS, stop, out, replan_budget_);
  }
}

void FlightSession::OnAddZone(const v1::FlightZone& zone, const StopCondition& stop,
                              Outputs* out) {
  absl::StatusOr<FlightZoneSpec> spec = ZoneFromProto(zone, env_.limits.zones, "add_zone");
  if (!spec.ok()) {
    Refuse("add_zone", std::string(spec.status().message()), out);
    return;
  }
  if (zones_.count(spec->id) != 0) {
    Refuse("add_zone.id", absl::StrFormat("add_zone.id '%s' is already a zone of the session; "
                                          "remove it first",
                                          spec->id),
           out);
    return;
  }
  if (zones_.size() >= env_.limits.zones.max_zones) {
    Refuse("add_zone", absl::StrFormat("the session already holds %d zones, its most (--max_flight_zones)",
                                       zones_.size()),
           out);
    return;
  }
  const bool active = spec->ActiveAt(now_s_);
  zones_.emplace(spec->id, *std::move(spec));
  if (!active) return;
  if (absl::Status s = BuildModel(stop); !s.ok()) {
    zones_.erase(zone.id());
    Refuse("add_zone", std::string(s.message()), out);
    return;
  }
  Replan(v1::FLIGHT_REASON_ZONE_ADDED, stop, out, replan_budget_);
}

void FlightSession::OnRemoveZone(const v1::RemoveZone& remove, const StopCondition& stop,
                                 Outputs* out) {
  auto it = zones_.find(remove.id());
  if (it == zones_.end()) {
    Refuse("remove_zone.id",
           absl::StrFormat("remove_zone.id '%s' is not a zone of the session", remove.id()), out);
    return;
  }
  const bool active = it->second.ActiveAt(now_s_);
  zones_.erase(it);
  if (!active) return;
  if (absl::Status s = BuildModel(stop); !s.ok()) {
    Refuse("remove_zone", std::string(s.message()), out);
    return;
  }
  Replan(v1::FLIGHT_REASON_ZONE_REMOVED, stop, out, replan_budget_);
}

void FlightSession::OnWind(const v1::WindChange& wind, const StopCondition& stop, Outputs* out) {
  ModelParams next = params_;
  next.wind_speed_mps = wind.wind_speed_mps();
  next.wind_from_deg = wind.wind_from_deg();
  if (absl::Status s = ValidateModelParams(next); !s.ok()) {
    Refuse("wind", absl::StrCat("wind: ", s.message()), out);
    return;
  }
  if (absl::Status s = CheckModelWork(next, env_.request_limits); !s.ok()) {
    Refuse("wind", absl::StrCat("wind: ", s.message()), out);
    return;
  }
  const ModelParams before = params_;
  params_ = next;
  if (absl::Status s = BuildModel(stop); !s.ok()) {
    params_ = before;
    (void)BuildModel(stop);
    Refuse("wind", absl::StrCat("wind: ", s.message()), out);
    return;
  }
  // The manoeuvres' ground turn radius and climb angle change with the wind:
  // the arcs are those of the new pieces.
  if (absl::Status s = RecomputeArcs(); !s.ok()) {
    Refuse("wind", std::string(s.message()), out);
    return;
  }
  progress_m_ = std::min(progress_m_, cum_.back());
  Replan(v1::FLIGHT_REASON_WIND, stop, out, replan_budget_);
}

std::vector<v1::FlightOutput> FlightSession::Search(const CancellationToken& cancel) {
  cancel_ = &cancel;
  const StopCondition stop(&cancel);
  Outputs out;
  if (!searching_ || ended_) return out;
  ++searches_;
  input_arrived_ = absl::Now();
  const v1::FlightAlertKind before = last_alert_;
  // Each search doubles the budget, up to 8 times the replanning budget.
  PlannerBudget budget = replan_budget_;
  const double factor = static_cast<double>(1 << std::min<uint64_t>(searches_, 3));
  budget.max_time_s *= factor;
  if (budget.max_iterations > 0) budget.max_iterations *= static_cast<int64_t>(factor);
  Outputs attempt;
  Replan(v1::FLIGHT_REASON_SEARCH, stop, &attempt, budget);
  for (v1::FlightOutput& o : attempt) {
    // An alert the client already has is not sent again.
    if (o.has_alert() && o.alert().kind() == before) continue;
    out.push_back(std::move(o));
  }
  return out;
}

}  // namespace riskplan::server
