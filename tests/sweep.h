// How much of a sweep over many fixed problems a test runs in this build.
//
// A few tests repeat the same check over a fixed set of problems (the 24
// demo-city scenarios, the 8 problems planned through a shim): the set is
// what gives them their power in the normal suite, which runs every problem.
// The sanitized builds (scripts/sanitize.sh) look for memory errors, undefined
// behaviour and races in the code paths a test reaches, and every problem of
// a sweep reaches the same paths on other numbers; there the sweep runs every
// kSweepStride-th problem, starting with the first. Under ASan the full
// scenario sweep of RISK_RRT_STAR took 133 s of the suite's 546 s
// (docs/reliability.md).
#ifndef RISKPLAN_TESTS_SWEEP_H_
#define RISKPLAN_TESTS_SWEEP_H_

#include <cstddef>

namespace riskplan::testing_sweep {

#ifdef RISKPLAN_SANITIZED_BUILD
inline constexpr bool kSanitizedBuild = true;
inline constexpr size_t kSweepStride = 3;
#else
inline constexpr bool kSanitizedBuild = false;
inline constexpr size_t kSweepStride = 1;
#endif

// How many of `n` problems a sweep with kSweepStride runs.
constexpr size_t SweptCount(size_t n) { return (n + kSweepStride - 1) / kSweepStride; }

}  // namespace riskplan::testing_sweep

#endif  // RISKPLAN_TESTS_SWEEP_H_
