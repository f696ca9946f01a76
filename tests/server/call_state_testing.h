// What the tests of the streams' state machines share (PlanCallState,
// FleetCallState): the check of a Step that finishes, the trace of events
// for failure messages, and the walk over every order of events.
#ifndef RISKPLAN_TESTS_SERVER_CALL_STATE_TESTING_H_
#define RISKPLAN_TESTS_SERVER_CALL_STATE_TESTING_H_

#include <cstddef>
#include <string>
#include <vector>

#include "grpcpp/support/status.h"
#include "gtest/gtest.h"

namespace riskplan::testing_call_state {

// `step` finishes the call with `code` and `message`, and writes nothing.
template <typename Step>
void ExpectFinish(const Step& step, grpc::StatusCode code, const std::string& message) {
  ASSERT_TRUE(step.finish.has_value());
  EXPECT_FALSE(step.write.has_value());
  EXPECT_EQ(step.finish->error_code(), code);
  EXPECT_EQ(step.finish->error_message(), message);
}

// The events of `trace` (indexes into `names`), comma-separated.
template <size_t N>
std::string EventTrace(const std::vector<int>& trace, const char* const (&names)[N]) {
  std::string text;
  for (int e : trace) text += std::string(text.empty() ? "" : ", ") + names[e];
  return text;
}

// Walks every order of up to `depth` events from `h`, depth first: at each
// harness reached, `check(h)` (that the call ends well from there); then,
// for each of `events` that `possible(h, e)`, on a copy, `apply(copy, e)`
// (which checks the step it returns) and the walk from the copy. Stops at
// the first failure (false), so that gtest reports one trace, not millions.
template <typename Harness, typename Event, size_t N, typename Possible, typename Apply,
          typename Check>
bool ExploreEveryOrder(const Harness& h, int depth, const Event (&events)[N], Possible possible,
                       Apply apply, Check check) {
  if (!check(h)) return false;
  if (depth == 0) return true;
  for (Event e : events) {
    if (!possible(h, e)) continue;
    Harness next = h;
    if (!apply(next, e) || !ExploreEveryOrder(next, depth - 1, events, possible, apply, check)) {
      return false;
    }
  }
  return true;
}

}  // namespace riskplan::testing_call_state

#endif  // RISKPLAN_TESTS_SERVER_CALL_STATE_TESTING_H_
