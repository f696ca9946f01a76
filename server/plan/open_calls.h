// OpenCalls: how many of the service's calls gRPC has not yet finished with
// (a reactor is counted from its creation to its OnDone). On SIGTERM the
// server waits for this to reach zero and then shuts gRPC down at once:
// waiting for gRPC's own Shutdown deadline instead would also wait for idle
// client connections to acknowledge the server's GOAWAY, which an idle client
// may take seconds to do (its channel is not being polled).
//
// Thread-safe.
#ifndef RISKPLAN_SERVER_PLAN_OPEN_CALLS_H_
#define RISKPLAN_SERVER_PLAN_OPEN_CALLS_H_

#include <cstdint>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"

namespace riskplan::server {

class OpenCalls {
 public:
  void Opened() {
    absl::MutexLock lock(&mu_);
    ++open_;
  }
  void Done() {
    absl::MutexLock lock(&mu_);
    --open_;
  }
  int64_t open() const {
    absl::MutexLock lock(&mu_);
    return open_;
  }
  // True once no call is open; false if `deadline` passes first.
  bool WaitUntilNone(absl::Time deadline) const {
    absl::MutexLock lock(&mu_);
    const auto none = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return open_ == 0; };
    return mu_.AwaitWithDeadline(absl::Condition(&none), deadline);
  }

 private:
  mutable absl::Mutex mu_;
  int64_t open_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_OPEN_CALLS_H_
