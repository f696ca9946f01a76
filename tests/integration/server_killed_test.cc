// What `riskplan plan` gives its user when the server dies mid-stream: the
// error (UNAVAILABLE), what it had received, and the best trajectory it got,
// still written to --trajectory_out and drawn with --picture; exit code 1.
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/child_process.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(ServerKilledTest, PlanKeepsTheBestTrajectoryItReceived) {
  char dir_template[] = "/tmp/riskplan-killed-XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  auto server = ServerProcess::Start();
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string cli = std::string(RISKPLAN_BIN_DIR) + "/riskplan ";

  // A plan of ten minutes (the server's cap), so only the kill ends it.
  auto plan = ChildProcess::Start(cli + (*server)->CliServerFlags() + " plan --start=" + kSmallCityStart +
                                  " --goal=" + kSmallCityGoal +
                                  " --budget_ms=600000 --min_update_interval_ms=0" +
                                  " --trajectory_out=" + dir + "/best.json --picture=" + dir +
                                  "/plan.svg 2>" + dir + "/stderr.txt");
  ASSERT_TRUE(plan.ok()) << plan.status();
  // Waits for the first improvement's row (sequence 1) on stdout, not for a
  // time.
  const std::regex first_row("\n +1 +[0-9.]+ +[0-9]+ +[0-9]+ +[0-9.e+-]+ +[0-9.]+\n");
  ASSERT_TRUE(
      (*plan)->ReadUntil([&](const std::string& out) { return std::regex_search(out, first_row); },
                         absl::Seconds(120)))
      << (*plan)->output() << ReadFile(dir + "/stderr.txt");
  (*server)->Signal(SIGKILL);
  (*server)->Wait(absl::Seconds(60));  // reaps it

  const std::optional<int> exit_code = (*plan)->Finish(absl::Seconds(120));
  const std::string err = ReadFile(dir + "/stderr.txt");
  EXPECT_EQ(exit_code, std::optional<int>(1)) << (*plan)->output() << err;
  EXPECT_THAT(err, HasSubstr("riskplan: PlanTrajectory failed: UNAVAILABLE"));
  std::smatch kept;
  ASSERT_TRUE(std::regex_search(
      err, kept,
      std::regex("received ([0-9]+) improvements before the stream ended; keeping the best: "
                 "risk ([0-9.e+-]+) expected casualties")))
      << err;
  EXPECT_GE(std::stoi(kept[1]), 1);
  const double printed_risk = std::stod(kept[2]);
  EXPECT_GT(printed_risk, 0.0);

  // The trajectory file parses, and it is the trajectory whose risk was
  // printed: evaluated again (on a new server with the same map), same risk.
  const nlohmann::json best = nlohmann::json::parse(ReadFile(dir + "/best.json"), nullptr, false);
  ASSERT_FALSE(best.is_discarded()) << ReadFile(dir + "/best.json");
  EXPECT_GE(best["waypoints"].size(), 2u);
  EXPECT_THAT(ReadFile(dir + "/plan.svg"), HasSubstr("<svg"));
  EXPECT_THAT(ReadFile(dir + "/plan.svg"), HasSubstr("UNAVAILABLE"));  // in the caption
  auto again = ServerProcess::Start();
  ASSERT_TRUE(again.ok()) << again.status();
  const CommandResult eval = RunCommand(cli + (*again)->CliServerFlags() +
                                        " eval --json --trajectory_file=" + dir + "/best.json");
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_NEAR(nlohmann::json::parse(eval.output)["risk"].get<double>(), printed_risk,
              1e-8 * printed_risk);  // printed with 9 significant digits
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace riskplan::testing
