// RISKPLAN_DCHECK itself, in both modes: this file forces the checks on; the
// translation unit of check_off_test.cc forces them off.
#undef NDEBUG
#define RISKPLAN_DCHECK_ALWAYS_ON 1
#include "core/base/check.h"

#include "gtest/gtest.h"

namespace riskplan {
namespace {

int Calls(int* counter) { return ++*counter; }

TEST(DcheckTest, PassingCheckEvaluatesItsConditionOnce) {
  static_assert(RISKPLAN_DCHECK_IS_ON == 1);
  int counter = 0;
  RISKPLAN_DCHECK(Calls(&counter) == 1);
  EXPECT_EQ(counter, 1);
}

TEST(DcheckDeathTest, FailingCheckNamesTheConditionFileAndLine) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const int size = 3;
  EXPECT_DEATH(RISKPLAN_DCHECK(size == 4),
               "check_test\\.cc:[0-9]+: RISKPLAN_DCHECK failed: size == 4");
}

}  // namespace
}  // namespace riskplan
