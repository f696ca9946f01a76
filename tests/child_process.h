// Commands that tests run, with deadlines: a command that hangs fails its
// test with what it printed, it does not hang the suite.
#ifndef RISKPLAN_TESTS_CHILD_PROCESS_H_
#define RISKPLAN_TESTS_CHILD_PROCESS_H_

#include <sys/types.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace riskplan::testing {

// How SpawnProcess starts a program.
struct SpawnOptions {
  int stdout_fd = -1;              // the child's stdout (-1: the test's own)
  int stderr_fd = -1;              // the child's stderr (-1: the test's own)
  bool own_process_group = false;  // in a new process group, led by the child
  int max_open_files = 0;          // > 0: the child runs with that RLIMIT_NOFILE
};

// Starts argv[0] (a path) with `argv` through posix_spawn: its pid, or what
// failed. Not fork: in a child of fork(), the handlers that libraries register
// with pthread_atfork run before exec, and PROJ's closes its SQLite databases,
// which frees memory. Under ASan that free waits forever for an allocator lock
// that another thread of the test held at the fork (about one run in ten under
// load: docs/reliability.md). posix_spawn runs no such handlers. A limit on
// open files goes through prlimit(1) (util-linux), which sets it and execs.
absl::StatusOr<pid_t> SpawnProcess(std::vector<std::string> argv, const SpawnOptions& options);

// `/bin/sh -c COMMAND` in a process group of its own, its stdout read through
// a pipe (stderr is inherited: redirect it in the command, e.g. `2>&1`).
// Not thread-safe; one thread reads and waits.
class ChildProcess {
 public:
  static absl::StatusOr<std::unique_ptr<ChildProcess>> Start(const std::string& command);
  // Kills the process group (SIGKILL) if the command still runs, and reaps it.
  ~ChildProcess();

  // Reads stdout until done(everything read so far) holds (true), or stdout
  // ends or `timeout` passes (false).
  bool ReadUntil(const std::function<bool(const std::string&)>& done, absl::Duration timeout);
  // Reads stdout to its end and waits for the command to exit, at most
  // `timeout` in all: its exit code, or nullopt when it died of a signal or
  // did not end in time (then timed_out() is true and its whole process group
  // has been killed).
  std::optional<int> Finish(absl::Duration timeout);

  // Sends `signal_number` to the whole process group.
  void SignalGroup(int signal_number);

  const std::string& command() const { return command_; }
  const std::string& output() const { return output_; }
  pid_t pid() const { return pid_; }
  bool timed_out() const { return timed_out_; }

 private:
  ChildProcess() = default;
  // Reads what is available within `timeout`: the bytes read, 0 when none
  // came, -1 at the end of stdout.
  int ReadSome(absl::Duration timeout);
  void KillAndReap();

  std::string command_;
  std::string output_;
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  bool reaped_ = false;
  bool timed_out_ = false;
};

// Runs a command line through /bin/sh; returns its exit code and stdout.
struct CommandResult {
  int exit_code = -1;  // -1: died of a signal, or timed out
  std::string output;
};
// A command still running after `timeout` is killed (its whole process
// group) and the calling test fails, naming the command and what it printed.
CommandResult RunCommand(const std::string& command, absl::Duration timeout = absl::Minutes(3));

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_CHILD_PROCESS_H_
