// What a fleet stream writes and how it ends: every transition of
// FleetCallState, and an exhaustive check that any order of events writes the
// finals in order without dropping one, the improvements one per mission and
// rate-limited, and finishes the call exactly once, never while a write is in
// flight, and never leaves it hanging.
#include "server/fleet/fleet_call_state.h"

#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "tests/server/call_state_testing.h"

namespace riskplan::server {
namespace {

using State = FleetCallState<std::string>;
using Step = State::Step;
using testing_call_state::ExpectFinish;

const absl::Time t0 = absl::FromUnixSeconds(1000);

bool IsNothing(const Step& step) {
  return !step.stop_planners && !step.write.has_value() && !step.finish.has_value();
}

void ExpectWrite(const Step& step, const std::string& message) {
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, message);
  EXPECT_FALSE(step.finish.has_value());
}

void ExpectCancelledFinish(const Step& step) {
  ExpectFinish(step, grpc::StatusCode::CANCELLED, "the call was cancelled");
}

// Three missions, none rate-limited, planned in `groups` groups.
State Started(int groups, std::vector<std::string> errors = {}) {
  State s;
  const Step step =
      s.Start(groups, std::vector<absl::Duration>(3, absl::ZeroDuration()), std::move(errors), t0);
  EXPECT_FALSE(step.stop_planners);
  EXPECT_FALSE(step.finish.has_value());
  return s;
}

// --- kCreated --------------------------------------------------------------------

TEST(FleetCallStateTest, StartWritesTheInvalidMissionsErrorsFirstInOrder) {
  State s;
  EXPECT_EQ(s.phase(), FleetCallPhase::kCreated);
  EXPECT_FALSE(s.takes_offers());
  Step step = s.Start(1, {absl::ZeroDuration(), absl::ZeroDuration()}, {"e0", "e1"}, t0);
  EXPECT_EQ(s.phase(), FleetCallPhase::kStreaming);
  EXPECT_TRUE(s.takes_offers());
  EXPECT_FALSE(step.stop_planners);
  ExpectWrite(step, "e0");
  EXPECT_TRUE(s.write_in_flight());
  ExpectWrite(s.WriteDone(t0), "e1");
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));  // the group still plans
  EXPECT_EQ(s.phase(), FleetCallPhase::kStreaming);
}

TEST(FleetCallStateTest, StartWithNothingToPlanOrWriteFinishesOk) {
  State s;
  ExpectFinish(s.Start(0, {}, {}, t0), grpc::StatusCode::OK, "");
  EXPECT_EQ(s.phase(), FleetCallPhase::kFinished);
  EXPECT_TRUE(s.ReportedStatus().ok());
}

TEST(FleetCallStateTest, StartWithOnlyErrorsFinishesOnceTheyAreWritten) {
  State s;
  ExpectWrite(s.Start(0, {absl::ZeroDuration(), absl::ZeroDuration()}, {"e0", "e1"}, t0), "e0");
  ExpectWrite(s.WriteDone(t0), "e1");
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::OK, "");
}

TEST(FleetCallStateTest, RejectBeforeStartFinishesOnce) {
  State s;
  const grpc::Status refused(grpc::StatusCode::RESOURCE_EXHAUSTED, "full");
  ExpectFinish(s.Reject(refused), grpc::StatusCode::RESOURCE_EXHAUSTED, "full");
  EXPECT_EQ(s.phase(), FleetCallPhase::kFinished);
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(IsNothing(s.Reject(grpc::Status(grpc::StatusCode::UNAVAILABLE, "draining"))));
  EXPECT_TRUE(IsNothing(s.Start(1, {absl::ZeroDuration()}, {"e0"}, t0)));
  EXPECT_EQ(s.phase(), FleetCallPhase::kFinished);
}

TEST(FleetCallStateTest, CancelBeforeStartWaitsForStart) {
  State s;
  // Nothing is queued yet: nothing to stop.
  EXPECT_TRUE(IsNothing(s.Cancel(CancelCause::kClient)));
  EXPECT_EQ(s.phase(), FleetCallPhase::kGoneBeforeStart);
  EXPECT_FALSE(s.takes_offers());
  EXPECT_EQ(s.cancel_cause(), CancelCause::kClient);
}

// --- kGoneBeforeStart ------------------------------------------------------------

TEST(FleetCallStateTest, StartAfterTheClientLeftStopsThePlannersAndWritesNothing) {
  State s;
  s.Cancel(CancelCause::kDeadline);
  Step step = s.Start(2, std::vector<absl::Duration>(3, absl::ZeroDuration()), {"e0"}, t0);
  EXPECT_TRUE(step.stop_planners);
  EXPECT_FALSE(step.write.has_value());
  EXPECT_FALSE(step.finish.has_value());
  EXPECT_EQ(s.phase(), FleetCallPhase::kStopping);
  EXPECT_FALSE(s.takes_offers());
  EXPECT_TRUE(IsNothing(s.OfferFinal(1, "f1", t0)));
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));
  ExpectCancelledFinish(s.GroupEnded(t0));
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_EQ(s.ReportedStatus().error_message(), "the call's deadline passed");
}

TEST(FleetCallStateTest, StartAfterTheClientLeftWithNoGroupsFinishesAtOnce) {
  State s;
  s.Cancel(CancelCause::kClient);
  Step step = s.Start(0, {absl::ZeroDuration()}, {"e0"}, t0);
  EXPECT_TRUE(step.stop_planners);
  ExpectCancelledFinish(step);
  EXPECT_EQ(s.ReportedStatus().error_message(), "the client cancelled");
}

TEST(FleetCallStateTest, RejectAfterTheClientLeftFinishesAndReportsTheCancel) {
  State s;
  s.Cancel(CancelCause::kClient);
  ExpectFinish(s.Reject(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "bad")),
               grpc::StatusCode::INVALID_ARGUMENT, "bad");
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::CANCELLED);
}

// --- kStreaming: what is written ---------------------------------------------------

TEST(FleetCallStateTest, FinalsAreWrittenInOrderOfArrivalAndNeverDropped) {
  State s = Started(2);
  ExpectWrite(s.OfferFinal(2, "f2", t0), "f2");
  EXPECT_TRUE(IsNothing(s.OfferFinal(0, "f0", t0)));
  EXPECT_TRUE(IsNothing(s.OfferFinal(1, "f1", t0)));
  ExpectWrite(s.WriteDone(t0), "f0");
  ExpectWrite(s.WriteDone(t0), "f1");
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
}

TEST(FleetCallStateTest, WaitingFinalsGoBeforeWaitingImprovements) {
  State s = Started(1);
  ExpectWrite(s.OfferImprovement(0, "i0", t0), "i0");
  EXPECT_TRUE(IsNothing(s.OfferImprovement(1, "i1", t0)));
  EXPECT_TRUE(IsNothing(s.OfferFinal(2, "f2", t0)));
  ExpectWrite(s.WriteDone(t0), "f2");
  ExpectWrite(s.WriteDone(t0), "i1");
}

TEST(FleetCallStateTest, ImprovementsWaitOnePerMissionTheNewestWinning) {
  State s = Started(1);
  ExpectWrite(s.OfferImprovement(0, "i0.1", t0), "i0.1");
  EXPECT_TRUE(IsNothing(s.OfferImprovement(1, "i1.1", t0)));
  EXPECT_TRUE(IsNothing(s.OfferImprovement(0, "i0.2", t0)));
  EXPECT_TRUE(IsNothing(s.OfferImprovement(1, "i1.2", t0)));
  EXPECT_TRUE(IsNothing(s.OfferImprovement(0, "i0.3", t0)));
  // By mission: 0's newest, then 1's newest.
  ExpectWrite(s.WriteDone(t0), "i0.3");
  ExpectWrite(s.WriteDone(t0), "i1.2");
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
}

TEST(FleetCallStateTest, ImprovementsAreRateLimitedPerMission) {
  State s;
  ASSERT_TRUE(IsNothing(s.Start(1, {absl::Milliseconds(100), absl::ZeroDuration()}, {}, t0)));
  ExpectWrite(s.OfferImprovement(0, "i0.1", t0), "i0.1");
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
  // Mission 0's next is not due for 100 ms; mission 1's goes at once.
  EXPECT_TRUE(IsNothing(s.OfferImprovement(0, "i0.2", t0 + absl::Milliseconds(10))));
  ExpectWrite(s.OfferImprovement(1, "i1.1", t0 + absl::Milliseconds(20)), "i1.1");
  // Still not due when that write completes: it waits for the next event.
  EXPECT_TRUE(IsNothing(s.WriteDone(t0 + absl::Milliseconds(50))));
  ExpectWrite(s.OfferImprovement(1, "i1.2", t0 + absl::Milliseconds(100)), "i0.2");
  ExpectWrite(s.WriteDone(t0 + absl::Milliseconds(110)), "i1.2");
}

TEST(FleetCallStateTest, AFinalReplacesItsMissionsWaitingImprovement) {
  State s = Started(1);
  ExpectWrite(s.OfferImprovement(0, "i0.1", t0), "i0.1");
  EXPECT_TRUE(IsNothing(s.OfferImprovement(0, "i0.2", t0)));
  EXPECT_TRUE(IsNothing(s.OfferImprovement(1, "i1.1", t0)));
  EXPECT_TRUE(IsNothing(s.OfferFinal(0, "f0", t0)));
  ExpectWrite(s.WriteDone(t0), "f0");
  ExpectWrite(s.WriteDone(t0), "i1.1");  // not i0.2: the final carries the best
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
}

// --- kStreaming: the end -------------------------------------------------------------

TEST(FleetCallStateTest, FinishesOkOnceEveryGroupHasEndedAndEveryFinalIsWritten) {
  State s = Started(2);
  ExpectWrite(s.OfferFinal(0, "f0", t0), "f0");
  EXPECT_TRUE(IsNothing(s.OfferFinal(1, "f1", t0)));
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));  // f0 in flight, f1 waiting
  EXPECT_EQ(s.groups_running(), 0);
  ExpectWrite(s.WriteDone(t0), "f1");
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::OK, "");
  EXPECT_TRUE(s.ReportedStatus().ok());
}

TEST(FleetCallStateTest, TheLastGroupEndingWithNothingInFlightFinishesOk) {
  State s = Started(1);
  ExpectWrite(s.OfferFinal(0, "f0", t0), "f0");
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
  ExpectFinish(s.GroupEnded(t0), grpc::StatusCode::OK, "");
}

TEST(FleetCallStateTest, CancelWhileStreamingDropsTheWaitingMessagesAndStops) {
  State s = Started(2);
  ExpectWrite(s.OfferFinal(0, "f0", t0), "f0");
  EXPECT_TRUE(IsNothing(s.OfferFinal(1, "f1", t0)));
  EXPECT_TRUE(IsNothing(s.OfferImprovement(2, "i2", t0)));
  Step step = s.Cancel(CancelCause::kClient);
  EXPECT_TRUE(step.stop_planners);
  EXPECT_FALSE(step.write.has_value());
  EXPECT_FALSE(step.finish.has_value());
  EXPECT_EQ(s.phase(), FleetCallPhase::kStopping);
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));  // f1 and i2 are not written
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));
  ExpectCancelledFinish(s.GroupEnded(t0));
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(s.ReportedStatus().error_message(), "the client cancelled");
}

TEST(FleetCallStateTest, CancelWhileTheLastWriteIsInFlightFinishesOnItsCompletion) {
  State s;
  ExpectWrite(s.Start(0, {absl::ZeroDuration()}, {"e0"}, t0), "e0");
  Step step = s.Cancel(CancelCause::kDeadline);
  EXPECT_TRUE(step.stop_planners);
  EXPECT_FALSE(step.finish.has_value());
  ExpectCancelledFinish(s.WriteDone(t0));
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

TEST(FleetCallStateTest, WriteFailedWhileStreamingStopsAsACancelDoes) {
  State s = Started(1);
  ExpectWrite(s.OfferFinal(0, "f0", t0), "f0");
  EXPECT_TRUE(IsNothing(s.OfferFinal(1, "f1", t0)));
  Step step = s.WriteFailed();
  EXPECT_TRUE(step.stop_planners);
  EXPECT_FALSE(step.write.has_value());
  EXPECT_FALSE(step.finish.has_value());  // the group still holds the call
  EXPECT_EQ(s.phase(), FleetCallPhase::kStopping);
  EXPECT_FALSE(s.write_in_flight());
  // Recorded as the client's cancel, until OnCancel says why.
  EXPECT_EQ(s.cancel_cause(), CancelCause::kClient);
  EXPECT_TRUE(IsNothing(s.Cancel(CancelCause::kDeadline)));
  ExpectCancelledFinish(s.GroupEnded(t0));
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

// --- kStopping -------------------------------------------------------------------------

TEST(FleetCallStateTest, StoppingIgnoresOffersAndWaitsForGroupsAndTheWriteInFlight) {
  State s = Started(2);
  ExpectWrite(s.OfferImprovement(0, "i0", t0), "i0");
  ASSERT_TRUE(s.Cancel(CancelCause::kClient).stop_planners);
  EXPECT_TRUE(IsNothing(s.OfferImprovement(0, "i0.2", t0)));
  EXPECT_TRUE(IsNothing(s.OfferFinal(0, "f0", t0)));
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));  // i0 is still in flight
  EXPECT_EQ(s.phase(), FleetCallPhase::kStopping);
  ExpectCancelledFinish(s.WriteFailed());
  EXPECT_EQ(s.ReportedStatus().error_message(), "the client cancelled");
}

TEST(FleetCallStateTest, StoppingFinishesWhenTheLastGroupEnds) {
  State s = Started(1);
  ExpectWrite(s.OfferImprovement(0, "i0", t0), "i0");
  ASSERT_TRUE(s.WriteFailed().stop_planners);
  // A second cancel stops nothing more.
  EXPECT_TRUE(IsNothing(s.Cancel(CancelCause::kClient)));
  ExpectCancelledFinish(s.GroupEnded(t0));
}

// --- kFinished is terminal ---------------------------------------------------------------

TEST(FleetCallStateTest, FinishedIsTerminal) {
  State s = Started(1);
  ExpectWrite(s.OfferFinal(0, "f0", t0), "f0");
  EXPECT_TRUE(IsNothing(s.GroupEnded(t0)));
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::OK, "");
  EXPECT_FALSE(s.takes_offers());
  EXPECT_TRUE(IsNothing(s.OfferImprovement(1, "i1", t0)));
  EXPECT_TRUE(IsNothing(s.OfferFinal(1, "f1", t0)));
  EXPECT_TRUE(IsNothing(s.Reject(grpc::Status(grpc::StatusCode::INTERNAL, "x"))));
  EXPECT_TRUE(IsNothing(s.Start(1, {absl::ZeroDuration()}, {"e0"}, t0)));
  // (No WriteDone or WriteFailed: nothing is in flight once finished.)
  EXPECT_FALSE(s.write_in_flight());
  // A late cancel stops nothing (every group has ended) but is reported.
  EXPECT_TRUE(IsNothing(s.Cancel(CancelCause::kDeadline)));
  EXPECT_EQ(s.phase(), FleetCallPhase::kFinished);
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

// --- every order of events ----------------------------------------------------------------

// The fleet of the exhaustive check: mission 0 is invalid (its error is the
// first final), missions 1 and 2 plan, in one group or in two.
constexpr int kMissions = 3;

// A model of gRPC, the scheduler and the groups around the state: which
// events can happen next, and what must hold after each.
struct Harness {
  Harness(absl::Duration interval, bool one_group)
      : interval(interval), groups(one_group ? 1 : 2), group_of{-1, 0, one_group ? 0 : 1} {}

  const absl::Duration interval;
  const int groups;
  const int group_of[kMissions];  // -1: invalid, never planned

  State state;
  absl::Time now = t0;
  bool started = false;    // Start happened
  bool rejected = false;   // Reject happened (only before Start)
  bool cancelled = false;  // OnCancel ran (gRPC runs it at most once)
  bool gone = false;       // OnCancel ran or a write failed
  bool stopped = false;    // a Step said stop_planners
  bool in_flight = false;
  int finishes = 0;
  bool final_offered[kMissions] = {};
  bool group_ended[2] = {};
  std::vector<std::string> finals_kept;       // in order, as the state took them
  std::vector<std::string> finals_written;    // in order
  std::string newest_improvement[kMissions];  // waiting, "" if none
  absl::Time improvement_written[kMissions] = {absl::InfinitePast(), absl::InfinitePast(),
                                               absl::InfinitePast()};
  int improvements = 0;
  std::vector<int> trace;  // the events so far (see Trace)
};

enum class Event {
  kStart,
  kReject,
  kImprove1,
  kImprove2,
  kFinal1,
  kFinal2,
  kGroupEnded0,
  kGroupEnded1,
  kWriteDone,
  kWriteFailed,
  kCancelClient,
  kCancelDeadline,
};
constexpr Event kEvents[] = {Event::kStart,       Event::kReject,       Event::kImprove1,
                             Event::kImprove2,    Event::kFinal1,       Event::kFinal2,
                             Event::kGroupEnded0, Event::kGroupEnded1,  Event::kWriteDone,
                             Event::kWriteFailed, Event::kCancelClient, Event::kCancelDeadline};

int MissionOf(Event e) { return (e == Event::kImprove1 || e == Event::kFinal1) ? 1 : 2; }

bool Possible(const Harness& h, Event e) {
  switch (e) {
    case Event::kStart:
    case Event::kReject:
      return !h.started && !h.rejected;  // the handler refuses or starts, once
    case Event::kImprove1:
    case Event::kImprove2:
    case Event::kFinal1:
    case Event::kFinal2: {
      // A mission's planner offers improvements, then its final, while its
      // group runs.
      const int m = MissionOf(e);
      return h.started && !h.group_ended[h.group_of[m]] && !h.final_offered[m];
    }
    case Event::kGroupEnded0:
    case Event::kGroupEnded1: {
      // A group ends once its missions have offered their finals, or when it
      // is dropped (the planners were stopped).
      const int g = e == Event::kGroupEnded0 ? 0 : 1;
      if (!h.started || g >= h.groups || h.group_ended[g]) return false;
      if (h.stopped) return true;
      for (int m = 0; m < kMissions; ++m) {
        if (h.group_of[m] == g && !h.final_offered[m]) return false;
      }
      return true;
    }
    case Event::kWriteDone:
    case Event::kWriteFailed:
      return h.in_flight;  // gRPC reports each write it was given, once
    case Event::kCancelClient:
    case Event::kCancelDeadline:
      return !h.cancelled;
  }
  return false;
}

// The events so far, for failure messages.
std::string Trace(const Harness& h) {
  static const char* const names[] = {"Start",         "Reject",         "Improve(1)",
                                      "Improve(2)",    "Final(1)",       "Final(2)",
                                      "GroupEnded(0)", "GroupEnded(1)",  "WriteDone",
                                      "WriteFailed",   "Cancel(client)", "Cancel(deadline)"};
  return testing_call_state::EventTrace(h.trace, names);
}

// Gives `e` to the state, keeping the harness's record of what it offered.
Step Deliver(Harness& h, Event e) {
  switch (e) {
    case Event::kStart: {
      h.started = true;
      // FleetCall counts the errors as ended missions only if the state takes them.
      if (h.state.phase() == FleetCallPhase::kCreated) h.finals_kept.push_back("e0");
      return h.state.Start(h.groups, {absl::ZeroDuration(), h.interval, h.interval}, {"e0"}, h.now);
    }
    case Event::kReject:
      h.rejected = true;
      return h.state.Reject(grpc::Status(grpc::StatusCode::UNAVAILABLE, "draining"));
    case Event::kImprove1:
    case Event::kImprove2: {
      const int m = MissionOf(e);
      const std::string update = "i" + std::to_string(m) + "." + std::to_string(++h.improvements);
      if (h.state.takes_offers()) h.newest_improvement[m] = update;
      return h.state.OfferImprovement(m, update, h.now);
    }
    case Event::kFinal1:
    case Event::kFinal2: {
      const int m = MissionOf(e);
      const std::string final_update = "f" + std::to_string(m);
      h.final_offered[m] = true;
      if (h.state.takes_offers()) {
        h.finals_kept.push_back(final_update);
        h.newest_improvement[m].clear();
      }
      return h.state.OfferFinal(m, final_update, h.now);
    }
    case Event::kGroupEnded0:
    case Event::kGroupEnded1:
      h.group_ended[e == Event::kGroupEnded0 ? 0 : 1] = true;
      return h.state.GroupEnded(h.now);
    case Event::kWriteDone:
      h.in_flight = false;
      return h.state.WriteDone(h.now);
    case Event::kWriteFailed:
      h.in_flight = false;
      h.gone = true;
      return h.state.WriteFailed();
    case Event::kCancelClient:
    case Event::kCancelDeadline:
      h.cancelled = true;
      h.gone = true;
      return h.state.Cancel(e == Event::kCancelClient ? CancelCause::kClient
                                                      : CancelCause::kDeadline);
  }
  return {};
}

bool AllGroupsEnded(const Harness& h) {
  for (int g = 0; g < h.groups; ++g) {
    if (!h.group_ended[g]) return false;
  }
  return true;
}

// A written message: finals in the order kept, none skipped; an improvement
// only once every waiting final is written, its mission's newest, never after
// its mission's final, and not before its mission's interval has passed.
void CheckWrite(Harness& h, const std::string& message) {
  if (message[0] == 'i') {
    const int m = message[1] - '0';
    EXPECT_EQ(h.finals_written.size(), h.finals_kept.size())
        << "an improvement before a waiting final after " << Trace(h);
    EXPECT_EQ(message, h.newest_improvement[m]) << "not the newest after " << Trace(h);
    EXPECT_GE(h.now - h.improvement_written[m], h.interval) << "too soon after " << Trace(h);
    h.newest_improvement[m].clear();
    h.improvement_written[m] = h.now;
    return;
  }
  const size_t next = h.finals_written.size();
  ASSERT_LT(next, h.finals_kept.size()) << "a final never offered after " << Trace(h);
  EXPECT_EQ(message, h.finals_kept[next]) << "finals out of order after " << Trace(h);
  h.finals_written.push_back(message);
}

// Checks Finish(status): once, with no write in flight; OK only with every
// group ended, every final written and the client there; CANCELLED only
// once the client is gone and every group has ended.
void CheckFinish(Harness& h, const grpc::Status& status) {
  EXPECT_FALSE(h.in_flight) << "Finish() with a write in flight after " << Trace(h);
  EXPECT_EQ(h.finishes, 0) << "Finish() twice after " << Trace(h);
  ++h.finishes;
  if (h.rejected) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << Trace(h);
  } else if (status.ok()) {
    EXPECT_FALSE(h.gone) << Trace(h);
    EXPECT_TRUE(AllGroupsEnded(h)) << "finished before its groups after " << Trace(h);
    EXPECT_EQ(h.finals_written, h.finals_kept) << "a final dropped after " << Trace(h);
  } else {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED) << Trace(h);
    EXPECT_TRUE(h.gone) << Trace(h);
    EXPECT_TRUE(AllGroupsEnded(h)) << "finished before its groups after " << Trace(h);
  }
}

// Applies `e` and checks the Step; returns false (with a test failure) when
// an invariant breaks.
bool Apply(Harness& h, Event e) {
  h.trace.push_back(static_cast<int>(e));
  h.now += absl::Milliseconds(40);
  const Step step = Deliver(h, e);
  if (step.stop_planners) {
    EXPECT_FALSE(h.stopped) << "stopped twice after " << Trace(h);
    EXPECT_TRUE(h.started && h.gone) << Trace(h);
    EXPECT_EQ(h.finishes, 0) << "stopped after Finish() after " << Trace(h);
    h.stopped = true;
  }
  if (step.write.has_value()) {
    EXPECT_FALSE(step.finish.has_value()) << Trace(h);
    EXPECT_FALSE(h.in_flight) << "two writes in flight after " << Trace(h);
    EXPECT_EQ(h.finishes, 0) << "a write after Finish() after " << Trace(h);
    EXPECT_FALSE(h.gone) << "a write to a gone client after " << Trace(h);
    CheckWrite(h, *step.write);
    h.in_flight = true;
  }
  if (step.finish.has_value()) CheckFinish(h, *step.finish);
  EXPECT_EQ(h.state.write_in_flight(), h.in_flight) << Trace(h);
  EXPECT_EQ(h.state.phase() == FleetCallPhase::kFinished, h.finishes > 0) << Trace(h);
  // A kept final never waits with nothing in flight: nothing else would
  // start its write.
  if (h.state.phase() == FleetCallPhase::kStreaming && !h.in_flight) {
    EXPECT_EQ(h.finals_written.size(), h.finals_kept.size()) << "a final stuck after " << Trace(h);
  }
  return !::testing::Test::HasFailure();
}

// Lets the call run to its end (the handler starts it if it has not yet,
// every mission offers its final, every group ends, every write completes,
// successfully or not) and checks that it finished exactly once.
bool FinishesWhenLeftToEnd(Harness h, bool writes_succeed) {
  const Event order[] = {writes_succeed ? Event::kWriteDone : Event::kWriteFailed,
                         Event::kStart,
                         Event::kFinal1,
                         Event::kFinal2,
                         Event::kGroupEnded0,
                         Event::kGroupEnded1};
  for (int i = 0; i < 20; ++i) {
    bool applied = false;
    for (Event e : order) {
      if (!Possible(h, e)) continue;
      if (!Apply(h, e)) return false;
      applied = true;
      break;
    }
    if (!applied) break;
  }
  EXPECT_FALSE(h.in_flight) << Trace(h);
  EXPECT_EQ(h.finishes, 1) << "left hanging after " << Trace(h);
  if (!h.gone && !h.rejected) {
    EXPECT_EQ(h.finals_written, h.finals_kept) << "a final dropped after " << Trace(h);
  }
  return !::testing::Test::HasFailure();
}

bool Explore(const Harness& h, int depth) {
  return testing_call_state::ExploreEveryOrder(
      h, depth, kEvents, Possible, Apply, [](const Harness& at) {
        return FinishesWhenLeftToEnd(at, true) && FinishesWhenLeftToEnd(at, false);
      });
}

TEST(FleetCallStateTest, EveryOrderOfEventsFinishesExactlyOnce) {
  // 100 ms between a mission's improvements, 40 ms per event: some wait for
  // a later event, others are replaced.
  for (bool one_group : {false, true}) {
    SCOPED_TRACE(one_group ? "one group" : "two groups");
    EXPECT_TRUE(Explore(Harness(absl::Milliseconds(100), one_group), 8));
    EXPECT_TRUE(Explore(Harness(absl::ZeroDuration(), one_group), 7));
  }
}

}  // namespace
}  // namespace riskplan::server
