#include "cmdline/help.h"

#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/str_split.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

// The flags of a small program with three commands, as a real one defines
// them: help texts that start with the commands that read the flag.
ABSL_FLAG(std::string, server, "127.0.0.1:50051", "riskplan-server address, HOST:PORT");
ABSL_FLAG(int64_t, budget_ms, 5000, "plan: time budget, ms (0: none)");
ABSL_FLAG(bool, tree, false, "plan: draw the planner's final tree");
ABSL_FLAG(std::string, waypoints, "", "eval, load: waypoints 'x,y,z,theta;...'");
ABSL_FLAG(bool, two_tier, false, "eval --two_tier: also run the two-tier check");
ABSL_FLAG(std::string, long_help, "a b",
          "load: a help text long enough to need wrapping at eighty columns, so that a "
          "terminal shows it without a line running past its right edge, however wide the "
          "words are");

namespace riskplan::cmdline {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

ProgramHelp TestHelp() {
  ProgramHelp help;
  help.program = "prog";
  help.usage = "a test program.\n\n  prog COMMAND [flags]";
  help.commands = {
      {"plan", "plan a trajectory", "  prog plan [--tree]", {"server", "budget_ms", "tree"}},
      {"eval", "evaluate a trajectory", "", {"server", "waypoints", "two_tier"}},
      {"load", "load test", "", {"server", "waypoints", "long_help"}},
  };
  help.footer = "Exit codes: 0 success.";
  return help;
}

std::optional<HelpRequest> Find(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  return FindHelpRequest(static_cast<int>(argv.size()), argv.data(), TestHelp());
}

TEST(FindHelpRequestTest, EveryHelpFlagAndTheCommandItIsAbout) {
  EXPECT_FALSE(Find({"prog"}).has_value());
  EXPECT_FALSE(Find({"prog", "plan", "--tree"}).has_value());
  for (const char* flag : {"--help", "-help", "-h", "--helpshort", "--helppackage"}) {
    std::optional<HelpRequest> r = Find({"prog", flag});
    ASSERT_TRUE(r.has_value()) << flag;
    EXPECT_EQ(r->command, "") << flag;
    EXPECT_FALSE(r->full) << flag;
  }
  EXPECT_TRUE(Find({"prog", "--helpfull"})->full);
  EXPECT_EQ(Find({"prog", "plan", "--help"})->command, "plan");
  EXPECT_EQ(Find({"prog", "--server=x", "-h", "eval"})->command, "eval");
  EXPECT_EQ(Find({"prog", "--help=load"})->command, "load");
  EXPECT_EQ(Find({"prog", "--helpon=plan"})->command, "plan");
  // Not a command: the whole program's help.
  EXPECT_EQ(Find({"prog", "frobnicate", "--help"})->command, "");
}

TEST(FindHelpRequestTest, NothingAfterTheEndOfFlags) {
  EXPECT_FALSE(Find({"prog", "plan", "--", "--help"}).has_value());
}

TEST(HelpTextTest, ProgramHelpListsCommandsAndEveryFlagWithItsDefault) {
  const std::string text = ProgramHelpText(TestHelp(), /*full=*/false);
  EXPECT_THAT(text, HasSubstr("prog: a test program.\n\n  prog COMMAND [flags]\n"));
  EXPECT_THAT(text, HasSubstr("  plan  plan a trajectory\n"));
  EXPECT_THAT(text, HasSubstr("  eval  evaluate a trajectory\n"));
  EXPECT_THAT(text, HasSubstr("--budget_ms=5000\n      plan: time budget, ms (0: none)\n"));
  EXPECT_THAT(text, HasSubstr("--server=127.0.0.1:50051\n"));
  EXPECT_THAT(text, HasSubstr("--tree=false\n"));
  EXPECT_THAT(text, HasSubstr("--waypoints=\"\"\n"));  // an empty default, quoted
  EXPECT_THAT(text, HasSubstr("--long_help=\"a b\"\n"));
  EXPECT_THAT(text, HasSubstr("Exit codes: 0 success.\n"));
  // Flags in alphabetical order.
  EXPECT_LT(text.find("--budget_ms="), text.find("--server="));
  // Abseil's own flags only with --helpfull; file names never.
  EXPECT_THAT(text, Not(HasSubstr("--flagfile")));
  EXPECT_THAT(ProgramHelpText(TestHelp(), /*full=*/true), HasSubstr("--flagfile="));
  for (bool full : {false, true}) {
    EXPECT_THAT(ProgramHelpText(TestHelp(), full),
                AllOf(Not(HasSubstr(".cc")), Not(HasSubstr("/tests/"))));
  }
}

TEST(HelpTextTest, LongProseIsWrappedAndExamplesAreNot) {
  ProgramHelp help = TestHelp();
  const std::string example = "  prog plan --tree " + std::string(70, 'x');
  help.usage =
      "a test program whose description is long enough to run past the eightieth "
      "column of a terminal.\n\n" +
      example;
  const std::string text = ProgramHelpText(help, /*full=*/false);
  EXPECT_THAT(text, HasSubstr("prog: a test program whose description is long enough to run past "
                              "the eightieth\ncolumn of a terminal.\n\n" +
                              example + "\n"));
}

TEST(HelpTextTest, LinesAreWrappedAtEightyColumns) {
  const std::string text = ProgramHelpText(TestHelp(), /*full=*/false);
  for (absl::string_view line : absl::StrSplit(text, '\n')) EXPECT_LE(line.size(), 80u) << line;
  EXPECT_THAT(text, HasSubstr("\n      a terminal"));  // continued under the same indent
}

TEST(HelpTextTest, CommandHelpListsItsFlagsOnlyInItsOrder) {
  absl::StatusOr<std::string> plan = CommandHelpText(TestHelp(), "plan");
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_THAT(*plan, HasSubstr("prog plan: plan a trajectory\n\n  prog plan [--tree]\n"));
  EXPECT_THAT(*plan, HasSubstr("--server="));
  EXPECT_THAT(*plan, HasSubstr("--tree=false"));
  EXPECT_THAT(*plan, Not(HasSubstr("--waypoints")));
  EXPECT_LT(plan->find("--server="), plan->find("--budget_ms="));
  EXPECT_LT(plan->find("--budget_ms="), plan->find("--tree="));
  // The list of commands that read a flag is left out under a command...
  EXPECT_THAT(*plan, HasSubstr("--budget_ms=5000\n      time budget, ms (0: none)\n"));
  absl::StatusOr<std::string> eval = CommandHelpText(TestHelp(), "eval");
  ASSERT_TRUE(eval.ok());
  EXPECT_THAT(*eval, HasSubstr("--waypoints=\"\"\n      waypoints 'x,y,z,theta;...'\n"));
  // ... but not a prefix that is more than a list of commands.
  EXPECT_THAT(*eval, HasSubstr("eval --two_tier: also run"));
  EXPECT_EQ(CommandHelpText(TestHelp(), "frobnicate").status().code(), absl::StatusCode::kNotFound);
}

TEST(HelpTextTest, BriefHelpHasTheCommandsAndNoFlags) {
  const std::string text = BriefHelpText(TestHelp());
  EXPECT_THAT(text, HasSubstr("  load  load test\n"));
  EXPECT_THAT(text, HasSubstr("`prog --help` lists every flag."));
  EXPECT_THAT(text, Not(HasSubstr("--server")));
}

TEST(CheckHelpTest, EveryFlagReadByACommandAndEveryNamedFlagDefined) {
  EXPECT_TRUE(CheckHelp(TestHelp()).ok()) << CheckHelp(TestHelp());
  ProgramHelp missing = TestHelp();
  missing.commands[0].flags.pop_back();  // --tree
  EXPECT_THAT(std::string(CheckHelp(missing).message()), HasSubstr("no command reads --tree"));
  ProgramHelp undefined = TestHelp();
  undefined.commands[1].flags.push_back("nonesuch");
  EXPECT_THAT(std::string(CheckHelp(undefined).message()),
              HasSubstr("eval names --nonesuch, which is not defined"));
  // A program without commands lists every flag itself.
  EXPECT_TRUE(CheckHelp(ProgramHelp{.program = "bench", .usage = "a benchmark"}).ok());
}

// ParseCommand's exits, in child processes.
void RunParseCommand(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  ParseCommand(static_cast<int>(argv.size()), argv.data(), TestHelp());
  std::exit(42);  // a command to run
}

TEST(ParseCommandDeathTest, HelpExitsZeroAndMistakesExitTwo) {
  EXPECT_EXIT(RunParseCommand({"prog", "plan"}), ::testing::ExitedWithCode(42), "");
  EXPECT_EXIT(RunParseCommand({"prog", "plan", "--help"}), ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(RunParseCommand({"prog", "--version"}), ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(RunParseCommand({"prog", "help", "plan"}), ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(RunParseCommand({"prog", "help"}), ::testing::ExitedWithCode(0), "");
  EXPECT_EXIT(RunParseCommand({"prog"}), ::testing::ExitedWithCode(2),
              "Commands .*\n  plan  plan a trajectory");
  EXPECT_EXIT(RunParseCommand({"prog", "frobnicate"}), ::testing::ExitedWithCode(2),
              "prog: unknown command 'frobnicate'; the commands are plan, eval, load");
  EXPECT_EXIT(RunParseCommand({"prog", "help", "frobnicate"}), ::testing::ExitedWithCode(2),
              "unknown command 'frobnicate'");
  EXPECT_EXIT(RunParseCommand({"prog", "plan", "tree"}), ::testing::ExitedWithCode(2),
              "prog plan: unexpected argument 'tree'");
  EXPECT_EXIT(RunParseCommand({"prog", "plan", "--budget_ms=soon"}), ::testing::ExitedWithCode(1),
              "Illegal value 'soon' specified for flag 'budget_ms'");
  EXPECT_EXIT(RunParseCommand({"prog", "plan", "--nonesuch"}), ::testing::ExitedWithCode(1),
              "Unknown command line flag 'nonesuch'");
}

}  // namespace
}  // namespace riskplan::cmdline
