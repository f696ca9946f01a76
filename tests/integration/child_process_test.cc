// The tests' own command runner: a command that hangs fails its test, with
// what it printed, and its whole process group is killed.
#include "tests/child_process.h"

#include <signal.h>

#include <fstream>
#include <string>

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

}  // namespace
}  // namespace riskplan::testing
