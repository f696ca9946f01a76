// RISKPLAN_DCHECK in a build with NDEBUG: the condition is compiled but never
// evaluated, and a false one does not abort.
#ifndef NDEBUG
#define NDEBUG 1
#endif
#undef RISKPLAN_DCHECK_ALWAYS_ON
#include "core/base/check.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

int Calls(int* counter) { return ++*counter; }

TEST(DcheckOffTest, ConditionIsNotEvaluatedAndDoesNotAbort) {
  static_assert(RISKPLAN_DCHECK_IS_ON == 0);
  int counter = 0;
  RISKPLAN_DCHECK(Calls(&counter) == 100);
  EXPECT_EQ(counter, 0);
}

}  // namespace
}  // namespace riskplan
