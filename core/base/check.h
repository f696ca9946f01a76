// RISKPLAN_DCHECK: preconditions and invariants, checked in debug builds.
//
// A header that says "REQUIRES: ..." backs it with RISKPLAN_DCHECK at the top
// of the function, and code that writes into a span it was handed checks the
// span's size the same way (as LevelDB's assert and Envoy's ASSERT do). A
// failed check is a bug in the caller, never bad input: input is validated
// and answered with a Status. In builds with NDEBUG (RelWithDebInfo, Release)
// the condition is not evaluated, so a check may be as thorough as it needs
// to be but must have no side effects. Define RISKPLAN_DCHECK_ALWAYS_ON to
// keep the checks in an NDEBUG build.
#ifndef RISKPLAN_CORE_BASE_CHECK_H_
#define RISKPLAN_CORE_BASE_CHECK_H_

#include <cstdio>
#include <cstdlib>

namespace riskplan::internal {

// Prints "FILE:LINE: RISKPLAN_DCHECK failed: CONDITION" to stderr and aborts.
[[noreturn]] inline void DcheckFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "%s:%d: RISKPLAN_DCHECK failed: %s\n", file, line, condition);
  std::fflush(stderr);
  std::abort();
}

}  // namespace riskplan::internal

#if !defined(NDEBUG) || defined(RISKPLAN_DCHECK_ALWAYS_ON)
#define RISKPLAN_DCHECK_IS_ON 1
#define RISKPLAN_DCHECK(condition) \
  (static_cast<bool>(condition)    \
       ? static_cast<void>(0)      \
       : ::riskplan::internal::DcheckFailed(#condition, __FILE__, __LINE__))
#else
#define RISKPLAN_DCHECK_IS_ON 0
// Not evaluated, but still compiled, so the condition cannot rot.
#define RISKPLAN_DCHECK(condition) static_cast<void>(sizeof(static_cast<bool>(condition)))
#endif

#endif  // RISKPLAN_CORE_BASE_CHECK_H_
