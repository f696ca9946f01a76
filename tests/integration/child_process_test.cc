// The tests' own command runner: a command that hangs fails its test, with
// what it printed, and its whole process group is killed; and how tests start
// programs (SpawnProcess: no fork, so no atfork handler runs).
#include "tests/child_process.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest-spi.h"
#include "gtest/gtest.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

// Whether process `pid` is gone (or a zombie, waiting for init to reap it).
bool Gone(int pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_text, name, state;
  if (!(stat >> pid_text >> name >> state)) return true;
  return state == "Z";
}

TEST(ChildProcessTest, RunCommandReturnsTheExitCodeAndStdout) {
  const CommandResult r = RunCommand("echo hello; echo ignored >&2; exit 3");
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.output, "hello\n");
}

TEST(ChildProcessTest, AHangingCommandFailsTheTestAndItsGroupIsKilled) {
  CommandResult r;
  // The command prints the pid of a child it leaves running, then hangs.
  EXPECT_NONFATAL_FAILURE(
      r = RunCommand("sleep 600 & echo child $!; wait", absl::Milliseconds(500)),
      "sleep 600 & echo child");
  EXPECT_EQ(r.exit_code, -1);
  ASSERT_THAT(r.output, HasSubstr("child "));
  const int child = std::stoi(r.output.substr(r.output.find("child ") + 6));
  // Killed with its group (reaped by init, whenever it gets to it).
  const absl::Time deadline = absl::Now() + absl::Seconds(30);
  while (!Gone(child) && absl::Now() < deadline) absl::SleepFor(absl::Milliseconds(10));
  EXPECT_TRUE(Gone(child));
  if (!Gone(child)) kill(child, SIGKILL);
}

TEST(ChildProcessTest, ReadUntilWaitsForOutputNotForTheEnd) {
  auto child = ChildProcess::Start("echo ready; sleep 600");
  ASSERT_TRUE(child.ok()) << child.status();
  EXPECT_TRUE((*child)->ReadUntil(
      [](const std::string& out) { return out.find("ready\n") != std::string::npos; },
      absl::Seconds(60)));
  // Destroying it kills the command; reading on meanwhile times out.
  EXPECT_FALSE((*child)->ReadUntil([](const std::string& out) { return out.size() > 6; },
                                   absl::Milliseconds(50)));
}

// Runs `argv` with its stdout in a pipe: what it printed and its exit code.
CommandResult Spawned(std::vector<std::string> argv, SpawnOptions options = {}) {
  CommandResult result;
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) {
    ADD_FAILURE() << "pipe failed";
    return result;
  }
  options.stdout_fd = out[1];
  absl::StatusOr<pid_t> pid = SpawnProcess(std::move(argv), options);
  close(out[1]);
  EXPECT_TRUE(pid.ok()) << pid.status();
  if (pid.ok()) {
    char buffer[512];
    ssize_t n = 0;
    while ((n = read(out[0], buffer, sizeof(buffer))) > 0) result.output.append(buffer, n);
    int status = 0;
    waitpid(*pid, &status, 0);
    if (WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
  }
  close(out[0]);
  return result;
}

// The defect this guards: a child of fork() ran PROJ's pthread_atfork child
// handler before exec, and under ASan its free() waited forever for a lock
// another thread held. A spawned program must run no atfork handler: neither
// the prepare handler (it would run here, in the test) nor the child handler
// (it would run in the child before exec; it writes to a pipe to be seen).
std::atomic<int> atfork_prepare_calls{0};
int atfork_child_marker_fd = -1;
void CountAtforkPrepare() { atfork_prepare_calls.fetch_add(1); }
void MarkAtforkChild() {
  if (atfork_child_marker_fd >= 0 && write(atfork_child_marker_fd, "c", 1) < 0) _exit(125);
}

TEST(SpawnProcessTest, RunsNoAtforkHandlerAndReportsTheExitCode) {
  int marker[2];
  ASSERT_EQ(pipe2(marker, O_CLOEXEC | O_NONBLOCK), 0);
  atfork_child_marker_fd = marker[1];
  ASSERT_EQ(pthread_atfork(&CountAtforkPrepare, nullptr, &MarkAtforkChild), 0);

  const CommandResult r = Spawned({"/bin/sh", "-c", "echo spawned; exit 3"});
  EXPECT_EQ(r.output, "spawned\n");
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(atfork_prepare_calls.load(), 0);
  char c = 0;
  EXPECT_EQ(read(marker[0], &c, 1), -1) << "the atfork child handler ran";

  // The handlers are live: a fork runs both (what SpawnProcess must not do).
  const pid_t forked = fork();
  if (forked == 0) _exit(0);
  ASSERT_GT(forked, 0);
  waitpid(forked, nullptr, 0);
  EXPECT_EQ(atfork_prepare_calls.load(), 1);
  EXPECT_EQ(read(marker[0], &c, 1), 1);
  atfork_child_marker_fd = -1;
  close(marker[0]);
  close(marker[1]);
}

TEST(SpawnProcessTest, AProgramThatCannotBeStartedIsAnErrorNamingIt) {
  absl::StatusOr<pid_t> pid = SpawnProcess({"/nonexistent/riskplan-server", "--x"}, {});
  ASSERT_FALSE(pid.ok());
  EXPECT_THAT(std::string(pid.status().message()),
              HasSubstr("cannot start /nonexistent/riskplan-server: No such file or directory"));
  EXPECT_FALSE(SpawnProcess({}, {}).ok());
}

TEST(SpawnProcessTest, TheLimitOnOpenFilesApplies) {
  const CommandResult r =
      Spawned({"/bin/sh", "-c", "ulimit -n; ulimit -Hn"}, SpawnOptions{.max_open_files = 64});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.output, "64\n64\n");
}

// /proc/self/stat's fifth field is the process group, the first the pid.
TEST(SpawnProcessTest, AnOwnProcessGroupIsLedByTheChild) {
  const std::string print_pid_and_group =
      "read -r pid comm state ppid pgrp rest < /proc/self/stat;"
      " echo \"$pid $pgrp\"";
  // `exec` so that /proc/self is the spawned shell's own process.
  const CommandResult own =
      Spawned({"/bin/sh", "-c", "exec /bin/sh -c '" + print_pid_and_group + "'"},
              SpawnOptions{.own_process_group = true});
  std::vector<std::string> fields = absl::StrSplit(absl::StripSuffix(own.output, "\n"), ' ');
  ASSERT_EQ(fields.size(), 2u) << own.output;
  EXPECT_EQ(fields[0], fields[1]) << "the child leads its own group";

  const CommandResult shared = Spawned({"/bin/sh", "-c", print_pid_and_group});
  fields = absl::StrSplit(absl::StripSuffix(shared.output, "\n"), ' ');
  ASSERT_EQ(fields.size(), 2u) << shared.output;
  EXPECT_EQ(fields[1], std::to_string(getpgrp())) << "without it, the test's group";
}

}  // namespace
}  // namespace riskplan::testing
