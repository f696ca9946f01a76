// SessionList: the sessions a gateway registry keeps (plans, flights), oldest
// first, under one mutex: admission against a bound of running sessions,
// room made by dropping the oldest ended ones, look-up by id, and the stop of
// them all at shutdown. `Session` has id(), ended() and Stop().
#ifndef RISKPLAN_WEB_SESSION_LIST_H_
#define RISKPLAN_WEB_SESSION_LIST_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "absl/synchronization/mutex.h"

namespace riskplan::web {

template <typename Session>
class SessionList {
 public:
  // Adds the session `make(id)` unless the list is stopped (Unavailable) or
  // `max_running` sessions run (ResourceExhausted with `busy` as its
  // message); first drops the oldest ended sessions while `max_kept` or more
  // are kept. The id is `prefix`, a counter and 64 random bits, so that a
  // page reconnecting to a restarted gateway cannot land on someone else's
  // session of the same number.
  absl::StatusOr<std::shared_ptr<Session>> Add(
      int max_running, int max_kept, const std::string& busy, const std::string& prefix,
      const std::function<std::shared_ptr<Session>(std::string id)>& make) {
    std::vector<std::shared_ptr<Session>> dropped;  // destroyed outside the lock
    absl::MutexLock lock(&mu_);
    if (stopped_) return absl::UnavailableError("the gateway is shutting down");
    int running = 0;
    for (const auto& s : sessions_) running += s->ended() ? 0 : 1;
    if (running >= max_running) return absl::ResourceExhaustedError(busy);
    for (auto it = sessions_.begin();
         it != sessions_.end() && static_cast<int>(sessions_.size()) >= max_kept;) {
      if ((*it)->ended()) {
        dropped.push_back(std::move(*it));
        it = sessions_.erase(it);
      } else {
        ++it;
      }
    }
    static thread_local std::mt19937_64 generator(std::random_device{}());
    std::shared_ptr<Session> session =
        make(absl::StrFormat("%s%x-%016x", prefix, ++counter_, generator()));
    sessions_.push_back(session);
    return session;
  }

  // The session `id`, or nullptr.
  std::shared_ptr<Session> Find(const std::string& id) const {
    absl::MutexLock lock(&mu_);
    for (const auto& s : sessions_) {
      if (s->id() == id) return s;
    }
    return nullptr;
  }

  int running() const {
    absl::MutexLock lock(&mu_);
    int running = 0;
    for (const auto& s : sessions_) running += s->ended() ? 0 : 1;
    return running;
  }

  // Stops every session and refuses new ones.
  void StopAll() {
    std::vector<std::shared_ptr<Session>> sessions;
    {
      absl::MutexLock lock(&mu_);
      stopped_ = true;
      sessions.swap(sessions_);
    }
    for (const auto& s : sessions) s->Stop();
  }

 private:
  mutable absl::Mutex mu_;
  std::vector<std::shared_ptr<Session>> sessions_ ABSL_GUARDED_BY(mu_);  // oldest first
  uint64_t counter_ ABSL_GUARDED_BY(mu_) = 0;
  bool stopped_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_SESSION_LIST_H_
