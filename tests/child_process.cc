#include "tests/child_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gtest/gtest.h"

namespace riskplan::testing {

absl::StatusOr<pid_t> SpawnProcess(std::vector<std::string> argv, const SpawnOptions& options) {
  if (argv.empty()) return absl::InvalidArgumentError("no program to start");
  if (options.max_open_files > 0) {
    argv.insert(
        argv.begin(),
        {"/usr/bin/prlimit",
         absl::StrCat("--nofile=", options.max_open_files, ":", options.max_open_files), "--"});
  }
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(a.data());
  args.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attributes;
  posix_spawn_file_actions_init(&actions);
  posix_spawnattr_init(&attributes);
  if (options.stdout_fd >= 0) posix_spawn_file_actions_adddup2(&actions, options.stdout_fd, 1);
  if (options.stderr_fd >= 0) posix_spawn_file_actions_adddup2(&actions, options.stderr_fd, 2);
  if (options.own_process_group) {
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attributes, 0);
  }
  pid_t pid = -1;
  const int error = posix_spawn(&pid, args[0], &actions, &attributes, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (error != 0) {
    return absl::InternalError(absl::StrCat("cannot start ", argv[0], ": ", strerror(error)));
  }
  return pid;
}

absl::StatusOr<std::unique_ptr<ChildProcess>> ChildProcess::Start(const std::string& command) {
  std::unique_ptr<ChildProcess> child(new ChildProcess);
  child->command_ = command;
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) return absl::InternalError("pipe failed");
  // The pipe's ends are close-on-exec; the dup2 onto stdout is not.
  absl::StatusOr<pid_t> pid = SpawnProcess(
      {"/bin/sh", "-c", command}, SpawnOptions{.stdout_fd = out[1], .own_process_group = true});
  close(out[1]);
  if (!pid.ok()) {
    close(out[0]);
    return pid.status();
  }
  child->pid_ = *pid;
  child->stdout_fd_ = out[0];
  return child;
}

ChildProcess::~ChildProcess() {
  KillAndReap();
  if (stdout_fd_ >= 0) close(stdout_fd_);
}

void ChildProcess::KillAndReap() {
  if (pid_ <= 0 || reaped_) return;
  kill(-pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
  reaped_ = true;
}

void ChildProcess::SignalGroup(int signal_number) {
  if (pid_ > 0 && !reaped_) kill(-pid_, signal_number);
}

int ChildProcess::ReadSome(absl::Duration timeout) {
  if (stdout_fd_ < 0) return -1;
  pollfd p{stdout_fd_, POLLIN, 0};
  const int ms = static_cast<int>(
      std::clamp<int64_t>(absl::ToInt64Milliseconds(timeout), 0, int64_t{1} << 30));
  if (poll(&p, 1, ms) <= 0) return 0;  // nothing yet (or EINTR)
  char buffer[4096];
  const ssize_t n = read(stdout_fd_, buffer, sizeof(buffer));
  if (n < 0 && errno == EINTR) return 0;
  if (n <= 0) {
    close(stdout_fd_);
    stdout_fd_ = -1;
    return -1;
  }
  output_.append(buffer, static_cast<size_t>(n));
  return static_cast<int>(n);
}

bool ChildProcess::ReadUntil(const std::function<bool(const std::string&)>& done,
                             absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (!done(output_)) {
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration() || ReadSome(left) < 0) return done(output_);
  }
  return true;
}

std::optional<int> ChildProcess::Finish(absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  int status = 0;
  // Polls for the exit between reads: something the command started in the
  // background may hold stdout open after the command itself has ended.
  while (!reaped_) {
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      reaped_ = true;
      break;
    }
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) {
      timed_out_ = true;
      KillAndReap();
      return std::nullopt;
    }
    if (ReadSome(std::min(left, absl::Milliseconds(20))) < 0) {
      absl::SleepFor(std::min(left, absl::Milliseconds(2)));
    }
  }
  // What it wrote before it exited is all in the pipe.
  while (ReadSome(absl::ZeroDuration()) > 0) {
  }
  if (!WIFEXITED(status)) return std::nullopt;
  return WEXITSTATUS(status);
}

CommandResult RunCommand(const std::string& command, absl::Duration timeout) {
  CommandResult result;
  absl::StatusOr<std::unique_ptr<ChildProcess>> child = ChildProcess::Start(command);
  if (!child.ok()) {
    ADD_FAILURE() << "cannot run " << command << ": " << child.status();
    return result;
  }
  const std::optional<int> code = (*child)->Finish(timeout);
  result.output = (*child)->output();
  if ((*child)->timed_out()) {
    ADD_FAILURE() << "command still running after " << timeout
                  << " (its process group was killed): " << command << "\nit printed:\n"
                  << result.output;
  }
  result.exit_code = code.value_or(-1);
  return result;
}

}  // namespace riskplan::testing
