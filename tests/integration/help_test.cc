// Every program's --help, as a new user meets it: exit 0, the program's (or
// one command's) flags listed by name, no build paths; and a wrong flag or
// command still refused with a message naming it.
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

struct Command {
  std::string name;
  std::vector<std::string> flags;      // each listed by `PROG NAME --help`
  std::vector<std::string> not_flags;  // other commands' flags, not listed
};

struct Program {
  std::string name;
  std::vector<std::string> flags;  // each listed by `PROG --help`
  std::vector<Command> commands;
};

CommandResult RunProgram(const std::string& args) {
  return RunCommand(std::string(RISKPLAN_BIN_DIR) + "/" + args + " 2>&1");
}

void ExpectNoBuildPaths(const std::string& output, const std::string& what) {
  EXPECT_THAT(output, Not(HasSubstr("/work/"))) << what;
  EXPECT_THAT(output, Not(HasSubstr(".cc"))) << what;
  EXPECT_THAT(output, Not(HasSubstr(RISKPLAN_SOURCE_DIR))) << what;
  EXPECT_THAT(output, Not(HasSubstr(RISKPLAN_BIN_DIR))) << what;
}

// Prose fits a terminal; only indented lines (synopses, examples) may be
// longer, to be copied whole.
void ExpectProseWithinEightyColumns(const std::string& output, const std::string& what) {
  for (absl::string_view line : absl::StrSplit(output, '\n')) {
    if (!absl::StartsWith(line, " ")) {
      EXPECT_LE(line.size(), 80u) << what << ": " << line;
    }
  }
}

// A flag as a help lists it: at the start of a line, with its default.
std::string Listed(const std::string& flag) { return "\n  --" + flag + "="; }

void ExpectHelp(const Program& p) {
  for (const char* help : {"--help", "-h", "-help", "--helpshort", "--helpfull"}) {
    const std::string what = p.name + " " + help;
    const CommandResult r = RunProgram(what);
    EXPECT_EQ(r.exit_code, 0) << what << "\n" << r.output;
    EXPECT_THAT(r.output, HasSubstr(p.name + ": ")) << what;
    for (const std::string& flag : p.flags) EXPECT_THAT(r.output, HasSubstr(Listed(flag))) << what;
    for (const Command& c : p.commands) {
      EXPECT_THAT(r.output, HasSubstr("\n  " + c.name + " ")) << what;
    }
    ExpectNoBuildPaths(r.output, what);
    ExpectProseWithinEightyColumns(r.output, what);
  }
  for (const Command& c : p.commands) {
    const std::string what = p.name + " " + c.name + " --help";
    const CommandResult r = RunProgram(what);
    EXPECT_EQ(r.exit_code, 0) << what << "\n" << r.output;
    EXPECT_THAT(r.output, HasSubstr(p.name + " " + c.name + ": ")) << what;
    for (const std::string& flag : c.flags) EXPECT_THAT(r.output, HasSubstr(Listed(flag))) << what;
    for (const std::string& flag : c.not_flags) {
      EXPECT_THAT(r.output, Not(HasSubstr(Listed(flag)))) << what;
    }
    ExpectNoBuildPaths(r.output, what);
    ExpectProseWithinEightyColumns(r.output, what);
    // The same help three ways.
    EXPECT_EQ(RunProgram(p.name + " help " + c.name).output, r.output) << what;
    EXPECT_EQ(RunProgram(p.name + " --help " + c.name).output, r.output) << what;
  }
  const CommandResult version = RunProgram(p.name + " --version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_THAT(version.output, ::testing::StartsWith(p.name + " 0."));
  // A wrong flag: refused, naming it, whatever the command.
  std::string wrong = p.name + " --no_such_flag";
  if (!p.commands.empty()) wrong = p.name + " " + p.commands[0].name + " --no_such_flag";
  const CommandResult r = RunProgram(wrong);
  EXPECT_NE(r.exit_code, 0) << wrong;
  EXPECT_THAT(r.output, HasSubstr("Unknown command line flag 'no_such_flag'")) << wrong;
}

// A program with commands and no command, or a wrong one: exit 2 with the
// commands listed or the wrong one named.
void ExpectCommandMistakes(const Program& p) {
  CommandResult r = RunProgram(p.name);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const Command& c : p.commands) EXPECT_THAT(r.output, HasSubstr("\n  " + c.name + " "));
  r = RunProgram(p.name + " frobnicate");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(p.name + ": unknown command 'frobnicate'; the commands are " +
                                  p.commands[0].name));
  r = RunProgram(p.name + " " + p.commands[0].name + " stray");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("unexpected argument 'stray'"));
  r = RunProgram(p.name + " help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, RunProgram(p.name + " --help").output);
}

TEST(HelpTest, Riskplan) {
  Program p{"riskplan", {}, {}};
  p.commands = {
      {"maps", {"server", "timeout_ms", "json"}, {"start", "waypoints", "rpc", "picture"}},
      {"eval",
       {"server", "map", "timeout_ms", "json", "waypoints", "polyline", "trajectory_file",
        "samples", "params", "wind", "two_tier", "two_tier_rule", "two_tier_detailed_segments",
        "two_tier_block_cells", "two_tier_bresenham"},
       {"start", "goal", "picture", "rpc", "concurrency"}},
      {"plan",
       {"server", "map", "timeout_ms", "start", "goal", "algorithm", "budget_ms", "iterations",
        "seed", "planner_params", "obstacles", "min_update_interval_ms", "display_step_m", "tree",
        "params", "wind", "picture", "picture_size", "trajectory_out"},
       {"waypoints", "json", "rpc", "concurrency", "two_tier"}},
      {"fleet",
       {"server", "map", "timeout_ms", "missions", "max_resubmits", "goal", "algorithm",
        "budget_ms", "iterations", "seed", "params", "wind", "picture", "picture_size",
        "trajectory_out"},
       {"waypoints", "json", "rpc", "concurrency"}},
      {"load",
       {"server", "map", "timeout_ms", "rpc", "mode", "concurrency", "rate", "duration_s",
        "max_outstanding", "ceiling", "report_json", "waypoints", "polyline", "trajectory_file",
        "params", "start", "goal", "algorithm", "budget_ms"},
       {"picture", "picture_size", "trajectory_out", "json", "max_resubmits"}},
  };
  for (const Command& c : p.commands) p.flags.insert(p.flags.end(), c.flags.begin(), c.flags.end());
  ExpectHelp(p);
  ExpectCommandMistakes(p);
}

TEST(HelpTest, RiskplanTool) {
  Program p{"riskplan-tool", {}, {}};
  p.commands = {
      {"evaluate",
       {"map", "waypoints", "polyline", "trajectory_file", "samples", "json", "params", "wind"},
       {"out", "agl_m", "seed"}},
      {"write-map", {"out", "seed", "size_m", "res_m", "params"}, {"map", "waypoints", "agl_m"}},
      {"info", {"map", "params"}, {"out", "waypoints", "agl_m", "seed"}},
      {"risk-layer",
       {"map", "out", "agl_m", "heading_deg", "threads", "stride", "params", "wind"},
       {"waypoints", "seed", "json"}},
  };
  for (const Command& c : p.commands) p.flags.insert(p.flags.end(), c.flags.begin(), c.flags.end());
  ExpectHelp(p);
  ExpectCommandMistakes(p);
}

TEST(HelpTest, RiskplanServer) {
  const Program p{"riskplan-server",
                  {"listen",
                   "maps",
                   "demo_city_size_m",
                   "plan_threads",
                   "max_running_plans",
                   "fleet_plan_slots",
                   "max_fleet_missions",
                   "max_admitted_missions",
                   "eval_threads",
                   "max_queued_evals",
                   "max_plan_time_ms",
                   "default_plan_time_ms",
                   "max_waypoints",
                   "max_obstacle_points",
                   "max_eval_samples",
                   "max_response_samples",
                   "max_request_bytes",
                   "model_cache_size",
                   "feasibility_cache_size",
                   "grace_period_ms",
                   "max_connection_age_ms",
                   "metrics_listen",
                   "rpc_log",
                   "cpu_workers",
                   "fpga_shims",
                   "accel_caller_runs",
                   "risk_cache_mb",
                   "cpu_kernel",
                   "prepared_map_cache_mb",
                   "blob_cache_mb",
                   "kernel_weights_cache_mb"},
                  {}};
  ExpectHelp(p);
  // The planners' parameters follow the flags.
  const CommandResult r = RunProgram("riskplan-server --help");
  EXPECT_THAT(r.output, HasSubstr("Planner parameters"));
  EXPECT_THAT(r.output, HasSubstr("RISK_RRT_STAR:"));
}

TEST(HelpTest, RiskplanFpgaShim) {
  ExpectHelp({"riskplan-fpga-shim",
              {"listen", "device", "format", "mmio_device", "mmio_base", "model_lanes",
               "rtl_config", "lanes", "report_clock_hz", "store_mb", "max_sites", "idle_timeout_s"},
              {}});
}

TEST(HelpTest, RiskplanWeb) {
  ExpectHelp({"riskplan-web",
              {"listen", "server", "assets_dir", "leaflet_dir", "chartjs_dir", "max_viewers",
               "request_threads", "max_running_plans", "max_kept_plans", "max_events_per_plan",
               "heartbeat_ms", "rpc_timeout_ms", "max_plan_time_ms", "max_flights",
               "max_flight_zones"},
              {}});
}

// Benchmarks with Abseil flags share the programs' help.
TEST(HelpTest, BenchPlannerAndCompareAndFingerprint) {
#if !defined(HAVE_RISKPLAN_BENCH_PLANNER) || !defined(HAVE_RISKPLAN_BENCH_COMPARE) || \
    !defined(HAVE_RISKPLAN_BENCH_FINGERPRINT)
  GTEST_SKIP() << "the benchmarks are not built (RISKPLAN_BUILD_BENCH=OFF)";
#endif
  ExpectHelp({"riskplan-bench-planner",
              {"seeds", "budget_s", "scenarios", "params", "iterations", "print_runs"},
              {}});
  ExpectHelp({"riskplan-bench-compare",
              {"seeds", "budget_s", "planners", "scenarios", "params", "per_scenario"},
              {}});
  ExpectHelp({"riskplan-bench-fingerprint", {"eval_only"}, {}});
}

TEST(HelpTest, BenchOmpl) {
#ifndef HAVE_RISKPLAN_BENCH_OMPL
  GTEST_SKIP() << "riskplan-bench-ompl is not built (no OMPL)";
#endif
  ExpectHelp({"riskplan-bench-ompl",
              {"planners", "scenarios", "seeds", "first_seed", "budget_s", "checkpoints", "params",
               "self_check", "bit_samples"},
              {}});
}

TEST(HelpTest, BenchRtl) {
#ifndef HAVE_RISKPLAN_BENCH_RTL
  GTEST_SKIP() << "riskplan-bench-rtl is not built (no Verilator)";
#endif
  ExpectHelp({"riskplan-bench-rtl", {"configs", "lanes", "config", "report_clock_hz"}, {}});
}

// Google Benchmark's programs answer --help themselves (exit 0, its own
// flags); riskplan-bench-shim adds its --shim.
TEST(HelpTest, GoogleBenchmarkPrograms) {
#if !defined(HAVE_RISKPLAN_BENCH_RISK) || !defined(HAVE_RISKPLAN_BENCH_SHIM) || \
    !defined(HAVE_RISKPLAN_BENCH_SHARED_TREE)
  GTEST_SKIP() << "the benchmarks are not built (RISKPLAN_BUILD_BENCH=OFF)";
#endif
  for (const char* program :
       {"riskplan-bench-risk", "riskplan-bench-accel", "riskplan-bench-shim",
        "riskplan-bench-seeds", "riskplan-bench-evaluate", "riskplan-bench-shared-tree"}) {
    CommandResult r = RunProgram(std::string(program) + " --help");
    EXPECT_EQ(r.exit_code, 0) << program << "\n" << r.output;
    EXPECT_THAT(r.output, HasSubstr("--benchmark_filter")) << program;
    ExpectNoBuildPaths(r.output, program);
    r = RunProgram(std::string(program) + " --no_such_flag");
    EXPECT_NE(r.exit_code, 0) << program;
    EXPECT_THAT(r.output, HasSubstr("no_such_flag")) << program;
  }
  EXPECT_THAT(RunProgram("riskplan-bench-shim --help").output, HasSubstr("--shim=HOST:PORT"));
}

}  // namespace
}  // namespace riskplan::testing
