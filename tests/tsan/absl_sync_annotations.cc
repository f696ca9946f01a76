// Happens-before edges for ThreadSanitizer through Debian's abseil, which is
// not built with TSan: absl::Mutex, CondVar and Notification synchronise with
// futexes and atomics inside libabsl_synchronization.so, where TSan cannot see
// them, so every field guarded by an absl::Mutex would be reported as a race.
//
// Loaded with LD_PRELOAD into the TSan pass's tests (scripts/sanitize.sh),
// this library interposes the library's exported functions, calls the real
// ones (dlsym(RTLD_NEXT)) and tells TSan what they did: a release on the
// mutex before every operation that can unlock it, an acquire after every one
// that returns with it held. Conditions that abseil evaluates inside the
// library (Mutex::Await, LockWhen) run with the mutex held, on the waiting
// thread or on the unlocking one, and after this library's release:
// - every unlock also releases, and every Condition::Eval acquires, one
//   shared object, so a condition sees what was written before it;
// - a condition evaluated inside an unlock, an Await or a LockWhen releases
//   that mutex again after it, so that its reads happen before the next
//   holder's writes (without this, a condition an Await evaluated before it
//   blocked was reported racing with the writer that woke it, a false report
//   CI's TSan pass made once in tests/accel/shim_tls_test.cc's EventLog).
// An over-approximation that can hide a race inside a condition but never
// reports a false one.
//
// Only the edges are modelled, not ownership: TSan's lock-order (deadlock)
// detection does not see absl::Mutex. The TSan runtime's functions are weak,
// so that a program without TSan that inherits LD_PRELOAD (a shell a test
// starts) still loads.
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "absl/time/time.h"

extern "C" {
void __tsan_acquire(void* addr) __attribute__((weak));
void __tsan_release(void* addr) __attribute__((weak));
}

namespace {

char condition_sync;  // released by every unlock, acquired by every Condition::Eval

// The mutex whose unlock, Await or LockWhen this thread is inside: a
// condition evaluated there releases it after reading.
thread_local const void* evaluating_under = nullptr;

class EvaluatingUnder {
 public:
  explicit EvaluatingUnder(const void* mu) : saved_(evaluating_under) { evaluating_under = mu; }
  ~EvaluatingUnder() { evaluating_under = saved_; }
  EvaluatingUnder(const EvaluatingUnder&) = delete;
  EvaluatingUnder& operator=(const EvaluatingUnder&) = delete;

 private:
  const void* const saved_;
};

void Acquire(const void* addr) {
  if (__tsan_acquire != nullptr) __tsan_acquire(const_cast<void*>(addr));
}

void Release(const void* addr) {
  if (__tsan_release != nullptr) {
    __tsan_release(const_cast<void*>(addr));
    __tsan_release(&condition_sync);
  }
}

// The next definition after this library of the abseil function whose
// mangled name is `prefix` "4absl" <inline namespace> `rest` (libabsl's).
// The inline namespace ("debian3" in Debian 12) comes from abseil's options.
template <typename F>
F Real(const char* prefix, const char* rest) {
  static_assert(sizeof(F) == sizeof(void*));
  const char* ns = ABSL_INTERNAL_TOKEN_STR(ABSL_OPTION_INLINE_NAMESPACE_NAME);
  const std::string symbol =
      std::string(prefix) + "4absl" + std::to_string(std::strlen(ns)) + ns + rest;
  void* f = dlsym(RTLD_NEXT, symbol.c_str());
  if (f == nullptr) {
    std::fprintf(stderr, "absl_sync_annotations: %s not found\n", symbol.c_str());
    std::abort();
  }
  return reinterpret_cast<F>(f);
}

// The real member function, `this` first (Itanium C++ ABI).
#define REAL(type, prefix, rest) static const auto real = Real<type>(prefix, rest)

}  // namespace

namespace absl {
ABSL_NAMESPACE_BEGIN

// Lock and unlock.

void Mutex::Lock() {
  REAL(void (*)(Mutex*), "_ZN", "5Mutex4LockEv");
  real(this);
  Acquire(this);
}

void Mutex::ReaderLock() {
  REAL(void (*)(Mutex*), "_ZN", "5Mutex10ReaderLockEv");
  real(this);
  Acquire(this);
}

bool Mutex::TryLock() {
  REAL(bool (*)(Mutex*), "_ZN", "5Mutex7TryLockEv");
  const bool locked = real(this);
  if (locked) Acquire(this);
  return locked;
}

bool Mutex::ReaderTryLock() {
  REAL(bool (*)(Mutex*), "_ZN", "5Mutex13ReaderTryLockEv");
  const bool locked = real(this);
  if (locked) Acquire(this);
  return locked;
}

void Mutex::Unlock() {
  REAL(void (*)(Mutex*), "_ZN", "5Mutex6UnlockEv");
  const EvaluatingUnder under(this);
  Release(this);
  real(this);
}

void Mutex::ReaderUnlock() {
  REAL(void (*)(Mutex*), "_ZN", "5Mutex12ReaderUnlockEv");
  const EvaluatingUnder under(this);
  Release(this);
  real(this);
}

// Lock when a condition holds: the mutex is held on return.

void Mutex::LockWhen(const Condition& cond) {
  REAL(void (*)(Mutex*, const Condition*), "_ZN", "5Mutex8LockWhenERKNS0_9ConditionE");
  const EvaluatingUnder under(this);
  real(this, &cond);
  Acquire(this);
}

void Mutex::ReaderLockWhen(const Condition& cond) {
  REAL(void (*)(Mutex*, const Condition*), "_ZN", "5Mutex14ReaderLockWhenERKNS0_9ConditionE");
  const EvaluatingUnder under(this);
  real(this, &cond);
  Acquire(this);
}

bool Mutex::LockWhenWithTimeout(const Condition& cond, Duration timeout) {
  REAL(bool (*)(Mutex*, const Condition*, Duration), "_ZN",
       "5Mutex19LockWhenWithTimeoutERKNS0_9ConditionENS0_8DurationE");
  const EvaluatingUnder under(this);
  const bool result = real(this, &cond, timeout);
  Acquire(this);
  return result;
}

bool Mutex::LockWhenWithDeadline(const Condition& cond, Time deadline) {
  REAL(bool (*)(Mutex*, const Condition*, Time), "_ZN",
       "5Mutex20LockWhenWithDeadlineERKNS0_9ConditionENS0_4TimeE");
  const EvaluatingUnder under(this);
  const bool result = real(this, &cond, deadline);
  Acquire(this);
  return result;
}

bool Mutex::ReaderLockWhenWithTimeout(const Condition& cond, Duration timeout) {
  REAL(bool (*)(Mutex*, const Condition*, Duration), "_ZN",
       "5Mutex25ReaderLockWhenWithTimeoutERKNS0_9ConditionENS0_8DurationE");
  const EvaluatingUnder under(this);
  const bool result = real(this, &cond, timeout);
  Acquire(this);
  return result;
}

bool Mutex::ReaderLockWhenWithDeadline(const Condition& cond, Time deadline) {
  REAL(bool (*)(Mutex*, const Condition*, Time), "_ZN",
       "5Mutex26ReaderLockWhenWithDeadlineERKNS0_9ConditionENS0_4TimeE");
  const EvaluatingUnder under(this);
  const bool result = real(this, &cond, deadline);
  Acquire(this);
  return result;
}

// Await: releases the mutex while it waits, holds it again on return.

void Mutex::Await(const Condition& cond) {
  REAL(void (*)(Mutex*, const Condition*), "_ZN", "5Mutex5AwaitERKNS0_9ConditionE");
  const EvaluatingUnder under(this);
  Release(this);
  real(this, &cond);
  Acquire(this);
}

bool Mutex::AwaitWithTimeout(const Condition& cond, Duration timeout) {
  REAL(bool (*)(Mutex*, const Condition*, Duration), "_ZN",
       "5Mutex16AwaitWithTimeoutERKNS0_9ConditionENS0_8DurationE");
  const EvaluatingUnder under(this);
  Release(this);
  const bool result = real(this, &cond, timeout);
  Acquire(this);
  return result;
}

bool Mutex::AwaitWithDeadline(const Condition& cond, Time deadline) {
  REAL(bool (*)(Mutex*, const Condition*, Time), "_ZN",
       "5Mutex17AwaitWithDeadlineERKNS0_9ConditionENS0_4TimeE");
  const EvaluatingUnder under(this);
  Release(this);
  const bool result = real(this, &cond, deadline);
  Acquire(this);
  return result;
}

bool Condition::Eval() const {
  REAL(bool (*)(const Condition*), "_ZNK", "9Condition4EvalEv");
  Acquire(&condition_sync);
  const bool result = real(this);
  if (evaluating_under != nullptr) Release(evaluating_under);
  return result;
}

// Condition variables: the same as Await.

void CondVar::Wait(Mutex* mu) {
  REAL(void (*)(CondVar*, Mutex*), "_ZN", "7CondVar4WaitEPNS0_5MutexE");
  Release(mu);
  real(this, mu);
  Acquire(mu);
}

bool CondVar::WaitWithTimeout(Mutex* mu, Duration timeout) {
  REAL(bool (*)(CondVar*, Mutex*, Duration), "_ZN",
       "7CondVar15WaitWithTimeoutEPNS0_5MutexENS0_8DurationE");
  Release(mu);
  const bool result = real(this, mu, timeout);
  Acquire(mu);
  return result;
}

bool CondVar::WaitWithDeadline(Mutex* mu, Time deadline) {
  REAL(bool (*)(CondVar*, Mutex*, Time), "_ZN",
       "7CondVar16WaitWithDeadlineEPNS0_5MutexENS0_4TimeE");
  Release(mu);
  const bool result = real(this, mu, deadline);
  Acquire(mu);
  return result;
}

// Notification: Notify happens before every wait that sees it.

void Notification::Notify() {
  REAL(void (*)(Notification*), "_ZN", "12Notification6NotifyEv");
  Release(this);
  real(this);
}

void Notification::WaitForNotification() const {
  REAL(void (*)(const Notification*), "_ZNK", "12Notification19WaitForNotificationEv");
  real(this);
  Acquire(this);
}

bool Notification::WaitForNotificationWithTimeout(Duration timeout) const {
  REAL(bool (*)(const Notification*, Duration), "_ZNK",
       "12Notification30WaitForNotificationWithTimeoutENS0_8DurationE");
  const bool notified = real(this, timeout);
  if (notified) Acquire(this);
  return notified;
}

bool Notification::WaitForNotificationWithDeadline(Time deadline) const {
  REAL(bool (*)(const Notification*, Time), "_ZNK",
       "12Notification31WaitForNotificationWithDeadlineENS0_4TimeE");
  const bool notified = real(this, deadline);
  if (notified) Acquire(this);
  return notified;
}

ABSL_NAMESPACE_END
}  // namespace absl
