// How a plan stream ends: every transition of PlanCallState, and an
// exhaustive check that any order of events finishes the call exactly once,
// never while a write is in flight, and never leaves it hanging.
#include "server/plan/plan_call_state.h"

#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "tests/server/call_state_testing.h"

namespace riskplan::server {
namespace {

using State = PlanCallState<std::string>;
using Step = State::Step;
using testing_call_state::ExpectFinish;

const absl::Time t0 = absl::FromUnixSeconds(1000);

bool IsNothing(const Step& step) {
  return !step.stop_planner && !step.wake_at.has_value() && !step.write.has_value() &&
         !step.finish.has_value();
}

// --- kPlanning ---------------------------------------------------------------

TEST(PlanCallStateTest, StartsPlanningAndWritesImprovements) {
  State s(absl::ZeroDuration());
  EXPECT_EQ(s.phase(), PlanCallPhase::kPlanning);
  Step step = s.Offer("a", t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "a");
  EXPECT_FALSE(step.finish.has_value());
  EXPECT_FALSE(step.stop_planner);
  EXPECT_TRUE(s.write_in_flight());
  // Newest wins while "a" is in flight.
  EXPECT_TRUE(IsNothing(s.Offer("b", t0)));
  EXPECT_TRUE(IsNothing(s.Offer("c", t0)));
  EXPECT_EQ(s.replaced(), 1);
  step = s.WriteDone(t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "c");
  EXPECT_EQ(s.phase(), PlanCallPhase::kPlanning);
}

TEST(PlanCallStateTest, MinimumIntervalAsksForAWakeUpAndPollWrites) {
  State s(absl::Milliseconds(100));
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
  Step step = s.Offer("b", t0 + absl::Milliseconds(10));
  EXPECT_FALSE(step.write.has_value());
  ASSERT_TRUE(step.wake_at.has_value());
  EXPECT_EQ(*step.wake_at, t0 + absl::Milliseconds(100));
  step = s.Poll(*step.wake_at);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "b");
}

// --- the normal end: kPlanning -> kFinalOffered -> kFinished -------------------

TEST(PlanCallStateTest, FinalIsWrittenAtOnceAndFinishesOkWhenWritten) {
  State s(absl::Seconds(10));
  Step step = s.EndPlan("final", t0);
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinalOffered);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "final");
  EXPECT_FALSE(step.finish.has_value());
  step = s.WriteDone(t0);
  ExpectFinish(step, grpc::StatusCode::OK, "");
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinished);
  EXPECT_TRUE(s.ReportedStatus().ok());
}

TEST(PlanCallStateTest, FinalWaitsForTheWriteInFlightAndReplacesThePendingUpdate) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.Offer("b", t0)));
  EXPECT_TRUE(IsNothing(s.EndPlan("final", t0)));
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinalOffered);
  EXPECT_EQ(s.replaced(), 1);  // "b": the final message carries the best
  Step step = s.WriteDone(t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "final");
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinalOffered);
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::OK, "");
}

TEST(PlanCallStateTest, ImprovementsAndWakeUpsAfterTheFinalAreIgnored) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.EndPlan("final", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.Offer("late", t0)));
  EXPECT_TRUE(IsNothing(s.Poll(t0)));
  EXPECT_TRUE(IsNothing(s.EndPlan("again", t0)));
  EXPECT_TRUE(IsNothing(s.RequestFinish(grpc::Status(grpc::StatusCode::INTERNAL, "x"))));
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::OK, "");
}

// --- refusal and planning errors: RequestFinish ----------------------------------

TEST(PlanCallStateTest, RejectBeforePlanningFinishesAtOnce) {
  State s(absl::ZeroDuration());
  const grpc::Status refused(grpc::StatusCode::RESOURCE_EXHAUSTED, "full");
  ExpectFinish(s.RequestFinish(refused), grpc::StatusCode::RESOURCE_EXHAUSTED, "full");
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinished);
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
}

TEST(PlanCallStateTest, FinishRequestedWhileAWriteIsInFlightWaitsForIt) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.Offer("b", t0)));  // pending behind "a"
  const grpc::Status error(grpc::StatusCode::INVALID_ARGUMENT, "start is not admissible");
  EXPECT_TRUE(IsNothing(s.RequestFinish(error)));
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinishWhenIdle);
  // A second end decided meanwhile does not replace the first.
  EXPECT_TRUE(IsNothing(s.RequestFinish(grpc::Status(grpc::StatusCode::INTERNAL, "other"))));
  EXPECT_TRUE(IsNothing(s.Poll(t0)));
  // "a" completes: finish with the kept status; "b" is never written.
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::INVALID_ARGUMENT, "start is not admissible");
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinished);
}

TEST(PlanCallStateTest, FinishRequestedWhileAWriteIsInFlightThatFails) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.RequestFinish(grpc::Status(grpc::StatusCode::INTERNAL, "bug"))));
  Step step = s.WriteFailed();
  EXPECT_TRUE(step.stop_planner);
  ExpectFinish(step, grpc::StatusCode::CANCELLED, "the stream broke");
  EXPECT_FALSE(s.write_in_flight());
}

// --- the client's cancel and deadline: Cancel ------------------------------------

TEST(PlanCallStateTest, CancelWhileQueuedEndsWithoutWriting) {
  State s(absl::ZeroDuration());
  Step step = s.Cancel(CancelCause::kClient);
  EXPECT_TRUE(step.stop_planner);
  EXPECT_FALSE(step.write.has_value());
  EXPECT_FALSE(step.finish.has_value());  // Run() has not ended: the call waits for it
  EXPECT_EQ(s.phase(), PlanCallPhase::kStopping);
  // Run() sees the cancelled token, skips planning and ends the plan.
  ExpectFinish(s.EndPlan("final", t0), grpc::StatusCode::CANCELLED, "the call was cancelled");
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(s.ReportedStatus().error_message(), "the client cancelled");
}

TEST(PlanCallStateTest, CancelDuringPlanningStopsWritingAndWaitsForTheWriteInFlight) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  EXPECT_TRUE(s.Cancel(CancelCause::kClient).stop_planner);
  EXPECT_EQ(s.phase(), PlanCallPhase::kStopping);
  EXPECT_TRUE(IsNothing(s.Offer("b", t0)));  // nobody reads it
  EXPECT_TRUE(IsNothing(s.Poll(t0)));
  // The planner returns; "a" is still in flight.
  EXPECT_TRUE(IsNothing(s.EndPlan("final", t0)));
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinishWhenIdle);
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::CANCELLED, "the call was cancelled");
}

TEST(PlanCallStateTest, CancelDuringPlanningWhoseWriteInFlightFails) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  s.Cancel(CancelCause::kClient);
  // The write fails before the planner has returned: still nothing to do.
  Step step = s.WriteFailed();
  EXPECT_TRUE(step.stop_planner);
  EXPECT_FALSE(step.finish.has_value());
  EXPECT_EQ(s.phase(), PlanCallPhase::kStopping);
  ExpectFinish(s.EndPlan("final", t0), grpc::StatusCode::CANCELLED, "the call was cancelled");
}

TEST(PlanCallStateTest, CancelDuringPlanningThenAPlanningError) {
  State s(absl::ZeroDuration());
  s.Cancel(CancelCause::kDeadline);
  const grpc::Status error(grpc::StatusCode::INTERNAL, "model");
  ExpectFinish(s.RequestFinish(error), grpc::StatusCode::INTERNAL, "model");
  // What the client saw, not the status given to Finish().
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

TEST(PlanCallStateTest, DeadlineAndClientCancelAreReportedApart) {
  State deadline(absl::ZeroDuration());
  deadline.Cancel(CancelCause::kDeadline);
  EXPECT_EQ(deadline.cancel_cause(), CancelCause::kDeadline);
  deadline.EndPlan("final", t0);
  EXPECT_EQ(deadline.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_EQ(deadline.ReportedStatus().error_message(), "the call's deadline passed");

  State client(absl::ZeroDuration());
  client.Cancel(CancelCause::kClient);
  EXPECT_EQ(client.cancel_cause(), CancelCause::kClient);
  client.EndPlan("final", t0);
  EXPECT_EQ(client.ReportedStatus().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(client.ReportedStatus().error_message(), "the client cancelled");
}

TEST(PlanCallStateTest, CancelAfterTheFinalWasOfferedLetsItsWriteEndTheCall) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.EndPlan("final", t0).write.has_value());
  EXPECT_TRUE(s.Cancel(CancelCause::kClient).stop_planner);
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinalOffered);
  ExpectFinish(s.WriteFailed(), grpc::StatusCode::CANCELLED, "the stream broke");
  EXPECT_EQ(s.ReportedStatus().error_message(), "the client cancelled");
}

TEST(PlanCallStateTest, CancelAfterFinishIsStillReported) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.EndPlan("final", t0).write.has_value());
  ASSERT_TRUE(s.WriteDone(t0).finish.has_value());
  Step step = s.Cancel(CancelCause::kDeadline);
  EXPECT_FALSE(step.finish.has_value());
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinished);
  EXPECT_EQ(s.ReportedStatus().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

// --- a failed write: WriteFailed -------------------------------------------------

TEST(PlanCallStateTest, WriteFailureDuringPlanningStopsAndRunEndsTheCall) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  Step step = s.WriteFailed();
  EXPECT_TRUE(step.stop_planner);
  EXPECT_FALSE(step.finish.has_value());  // the planner still holds the call
  EXPECT_EQ(s.phase(), PlanCallPhase::kStopping);
  EXPECT_FALSE(s.write_in_flight());
  EXPECT_TRUE(IsNothing(s.Offer("b", t0)));
  // Nothing in flight: the end finishes at once (no wait for a completion
  // that will never come).
  ExpectFinish(s.EndPlan("final", t0), grpc::StatusCode::CANCELLED, "the call was cancelled");
  EXPECT_EQ(s.ReportedStatus().error_message(), "the call was cancelled");
}

TEST(PlanCallStateTest, WriteFailureOfTheFinalMessageFinishes) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.EndPlan("final", t0).write.has_value());
  Step step = s.WriteFailed();
  EXPECT_TRUE(step.stop_planner);
  ExpectFinish(step, grpc::StatusCode::CANCELLED, "the stream broke");
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinished);
}

TEST(PlanCallStateTest, WriteFailureWhileTheFinalWaitsFinishesWithoutIt) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.EndPlan("final", t0)));
  ExpectFinish(s.WriteFailed(), grpc::StatusCode::CANCELLED, "the stream broke");
}

// --- shutdown -----------------------------------------------------------------------

TEST(PlanCallStateTest, ShutdownStopsThePlannerAndTheFinalIsStillWritten) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(s.Offer("a", t0).write.has_value());
  Step step = s.Shutdown();
  EXPECT_TRUE(step.stop_planner);
  EXPECT_FALSE(step.finish.has_value());
  EXPECT_TRUE(s.stopped_by_shutdown());
  EXPECT_EQ(s.phase(), PlanCallPhase::kPlanning);
  EXPECT_TRUE(IsNothing(s.WriteDone(t0)));
  ASSERT_TRUE(s.EndPlan("final", t0).write.has_value());
  ExpectFinish(s.WriteDone(t0), grpc::StatusCode::OK, "");
  EXPECT_TRUE(s.ReportedStatus().ok());
}

TEST(PlanCallStateTest, ShutdownWhileQueuedStillSendsTheFinalMessage) {
  State s(absl::ZeroDuration());
  s.Shutdown();
  Step step = s.EndPlan("final", t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "final");
}

// --- kFinished is terminal ------------------------------------------------------------

TEST(PlanCallStateTest, FinishesExactlyOnce) {
  State s(absl::ZeroDuration());
  ASSERT_TRUE(
      s.RequestFinish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "draining")).finish.has_value());
  EXPECT_FALSE(s.RequestFinish(grpc::Status::OK).finish.has_value());
  EXPECT_FALSE(s.EndPlan("final", t0).finish.has_value());
  EXPECT_FALSE(s.EndPlan("final", t0).write.has_value());
  EXPECT_TRUE(IsNothing(s.Offer("a", t0)));
  EXPECT_TRUE(IsNothing(s.Poll(t0)));
  // (No WriteDone or WriteFailed: nothing is in flight once finished.)
  EXPECT_FALSE(s.write_in_flight());
  EXPECT_FALSE(s.Shutdown().finish.has_value());
  EXPECT_FALSE(s.Cancel(CancelCause::kClient).finish.has_value());
  EXPECT_EQ(s.phase(), PlanCallPhase::kFinished);
}

// --- every order of events ------------------------------------------------------------

// A model of gRPC and Run() around the state: which events can happen next,
// and what must hold after each.
struct Harness {
  explicit Harness(absl::Duration interval) : state(interval) {}

  State state;
  absl::Time now = t0;
  bool in_flight = false;  // a write was started and has not completed
  bool run_ended = false;  // EndPlan or RequestFinish from Run() happened
  bool cancelled = false;  // OnCancel ran (gRPC runs it at most once)
  bool final_written = false;
  int finishes = 0;
  int improvements = 0;
  std::vector<int> trace;  // the events so far (see Trace)
};

enum class Event {
  kOffer,
  kPoll,
  kEndPlan,
  kRequestFinish,
  kWriteDone,
  kWriteFailed,
  kCancelClient,
  kCancelDeadline,
  kShutdown,
};
constexpr Event kEvents[] = {Event::kOffer,         Event::kPoll,           Event::kEndPlan,
                             Event::kRequestFinish, Event::kWriteDone,      Event::kWriteFailed,
                             Event::kCancelClient,  Event::kCancelDeadline, Event::kShutdown};

bool Possible(const Harness& h, Event e) {
  switch (e) {
    case Event::kOffer:
    case Event::kEndPlan:
    case Event::kRequestFinish:
      return !h.run_ended;  // Run() offers, then ends once
    case Event::kWriteDone:
    case Event::kWriteFailed:
      return h.in_flight;  // gRPC reports each write it was given, once
    case Event::kCancelClient:
    case Event::kCancelDeadline:
      return !h.cancelled;
    default:
      return true;
  }
}

// The events so far, for failure messages.
std::string Trace(const Harness& h) {
  static const char* const names[] = {
      "Offer",       "Poll",           "EndPlan",          "RequestFinish", "WriteDone",
      "WriteFailed", "Cancel(client)", "Cancel(deadline)", "Shutdown"};
  return testing_call_state::EventTrace(h.trace, names);
}

// Applies `e` and checks the Step; returns false (with a test failure) when
// an invariant breaks.
bool Apply(Harness& h, Event e) {
  h.trace.push_back(static_cast<int>(e));
  h.now += absl::Milliseconds(40);
  const bool was_finished = h.finishes > 0;
  Step step;
  switch (e) {
    case Event::kOffer:
      step = h.state.Offer("u" + std::to_string(++h.improvements), h.now);
      break;
    case Event::kPoll:
      step = h.state.Poll(h.now);
      break;
    case Event::kEndPlan:
      h.run_ended = true;
      step = h.state.EndPlan("final", h.now);
      break;
    case Event::kRequestFinish:
      h.run_ended = true;
      step = h.state.RequestFinish(grpc::Status(grpc::StatusCode::INTERNAL, "error"));
      break;
    case Event::kWriteDone:
      h.in_flight = false;
      step = h.state.WriteDone(h.now);
      break;
    case Event::kWriteFailed:
      h.in_flight = false;
      step = h.state.WriteFailed();
      EXPECT_TRUE(step.stop_planner);
      break;
    case Event::kCancelClient:
    case Event::kCancelDeadline:
      h.cancelled = true;
      step =
          h.state.Cancel(e == Event::kCancelClient ? CancelCause::kClient : CancelCause::kDeadline);
      EXPECT_TRUE(step.stop_planner);
      break;
    case Event::kShutdown:
      step = h.state.Shutdown();
      EXPECT_TRUE(step.stop_planner);
      break;
  }
  if (step.write.has_value()) {
    EXPECT_FALSE(step.finish.has_value()) << Trace(h);
    EXPECT_FALSE(h.in_flight) << "two writes in flight after " << Trace(h);
    EXPECT_FALSE(was_finished) << "a write after Finish() after " << Trace(h);
    EXPECT_FALSE(h.final_written) << "a write after the final message after " << Trace(h);
    h.in_flight = true;
    if (*step.write == "final") h.final_written = true;
  }
  if (step.finish.has_value()) {
    EXPECT_FALSE(h.in_flight) << "Finish() with a write in flight after " << Trace(h);
    EXPECT_FALSE(was_finished) << "Finish() twice after " << Trace(h);
    // OK only once the final message is written.
    if (step.finish->ok()) {
      EXPECT_TRUE(h.final_written) << Trace(h);
    }
    ++h.finishes;
  }
  EXPECT_EQ(h.state.write_in_flight(), h.in_flight) << Trace(h);
  EXPECT_EQ(h.state.phase() == PlanCallPhase::kFinished, h.finishes > 0) << Trace(h);
  return !::testing::Test::HasFailure();
}

// Lets the call run to its end (Run() ends it if it has not yet, every write
// completes, successfully or not) and checks that it finished exactly once.
bool FinishesWhenLeftToEnd(Harness h, bool writes_succeed) {
  for (int i = 0; i < 10 && (h.in_flight || !h.run_ended); ++i) {
    if (h.in_flight) {
      if (!Apply(h, writes_succeed ? Event::kWriteDone : Event::kWriteFailed)) return false;
    } else {
      if (!Apply(h, Event::kEndPlan)) return false;
    }
  }
  EXPECT_FALSE(h.in_flight) << Trace(h);
  EXPECT_EQ(h.finishes, 1) << "left hanging after " << Trace(h);
  return !::testing::Test::HasFailure();
}

bool Explore(const Harness& h, int depth) {
  return testing_call_state::ExploreEveryOrder(
      h, depth, kEvents, Possible, Apply, [](const Harness& at) {
        return FinishesWhenLeftToEnd(at, true) && FinishesWhenLeftToEnd(at, false);
      });
}

TEST(PlanCallStateTest, EveryOrderOfEventsFinishesExactlyOnce) {
  // 100 ms between updates, 40 ms per event: some updates are held back and
  // sent by Poll, others replaced.
  EXPECT_TRUE(Explore(Harness(absl::Milliseconds(100)), 8));
  EXPECT_TRUE(Explore(Harness(absl::ZeroDuration()), 7));
}

}  // namespace
}  // namespace riskplan::server
