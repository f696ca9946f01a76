// The `riskplan` CLI against the real server.
#include <png.h>
#include <signal.h>

#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

class CliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto server = ServerProcess::Start();
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
    char dir[] = "/tmp/riskplan-cli-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    dir_ = new std::string(dir);
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
    RunCommand("rm -rf " + *dir_);
    delete dir_;
  }

  static CommandResult Cli(const std::string& args) {
    return RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan " + server_->CliServerFlags() +
                      " " + args + " 2>&1");
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  static ServerProcess* server_;
  static std::string* dir_;
};

// How many pixels of the PNG at `path` have colour (r, g, b); -1 when it
// cannot be read.
int CountPngPixels(const std::string& path, int r, int g, int b, int* width, int* height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return -1;
  image.format = PNG_FORMAT_RGBA;
  std::vector<png_byte> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) return -1;
  *width = static_cast<int>(image.width);
  *height = static_cast<int>(image.height);
  int n = 0;
  for (size_t i = 0; i + 3 < pixels.size(); i += 4) {
    n += pixels[i] == r && pixels[i + 1] == g && pixels[i + 2] == b;
  }
  return n;
}

ServerProcess* CliTest::server_ = nullptr;
std::string* CliTest::dir_ = nullptr;

TEST_F(CliTest, Maps) {
  CommandResult r = Cli("maps");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("demo-city: 2000 x 2000 m (400 x 400 cells of 5 m)"));
  r = Cli("maps --json");
  EXPECT_EQ(r.exit_code, 0);
  nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["maps"][0]["name"], "demo-city");
  EXPECT_EQ(j["maps"][0]["nx"], 400);
}

TEST_F(CliTest, EvalFromFlagsAndFromAFile) {
  CommandResult r = Cli("eval --polyline='300,375,240; 1700,1625,250'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("expected casualties per flight"));
  const std::string file = *dir_ + "/traj.json";
  std::ofstream(file) << R"({"polyline": [[300, 375, 240], [1700, 1625, 250]]})";
  CommandResult from_file = Cli("eval --trajectory_file=" + file);
  EXPECT_EQ(from_file.exit_code, 0);
  EXPECT_EQ(from_file.output, r.output);  // same trajectory, same answer
  CommandResult json =
      Cli("eval --json --samples --waypoints='300,375,240,0.785; "
          "1700,1625,250,0.785'");
  nlohmann::json j = nlohmann::json::parse(json.output);
  EXPECT_GT(j["risk"].get<double>(), 0.0);
  EXPECT_EQ(j["samples"].size(), std::stoul(j["sample_count"].get<std::string>()));
}

TEST_F(CliTest, EvalErrors) {
  CommandResult r = Cli("eval --polyline='300,375,nan; 1700,1625,250'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("polyline point 0"));
  r = Cli("eval --map=nowhere --polyline='300,375,240; 1700,1625,250'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output, HasSubstr("EvaluateRisk failed: NOT_FOUND: map 'nowhere'"));
  r = Cli("frobnicate");
  EXPECT_EQ(r.exit_code, 2);
}

TEST_F(CliTest, WindFlag) {
  const std::string leg = " --polyline='300,1000,250; 1700,1000,250'";
  // Bad forms never reach the server: exit 2 and the flag named.
  for (const char* bad : {"8", "8@west", "-1@270", "nan@0"}) {
    CommandResult r = Cli(std::string("eval --wind='") + bad + "'" + leg);
    EXPECT_EQ(r.exit_code, 2) << bad << r.output;
    EXPECT_THAT(r.output, HasSubstr(std::string("--wind='") + bad + "' is not SPEED@FROM_DEG"));
  }
  // Too strong for the airspeed: the server's error names the field.
  CommandResult r = Cli("eval --wind=10@270" + leg);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wind.from.speed_mps has value 10; it must be at most"));
  // A west wind on a leg east: the answer's wind, and its flight time.
  r = Cli("eval --wind=8@270" + leg);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wind 8 m/s from 270.0 deg (grid north)"));
  EXPECT_THAT(r.output, HasSubstr("flight time 53.8 s"));  // 1400 m at 26 m/s
  CommandResult calm = Cli("eval" + leg);
  EXPECT_THAT(calm.output, HasSubstr("flight time 77.8 s"));  // 1400 m at 18 m/s
  EXPECT_THAT(calm.output, ::testing::Not(HasSubstr("wind ")));
  // plan and fleet send it too; a plan prints the wind it was planned in.
  r = Cli("plan --wind=5@0 --start=300,375,240,0.785 --goal=1700,1625,250,0.785 --budget_ms=0 "
          "--iterations=200");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wind 5 m/s from 0.0 deg"));
  const std::string missions = *dir_ + "/wind-fleet.json";
  std::ofstream(missions) << R"({"missions": [
      {"id": "calm", "start": "300,375,240,0.785"},
      {"id": "windy", "start": "300,375,240,0.785", "wind": "4@90"},
      {"id": "gale", "start": "300,375,240,0.785", "wind": "40@90"}]})";
  const std::string svg = *dir_ + "/wind-fleet.svg";
  r = Cli("fleet --missions=" + missions +
          " --goal=1700,1625,250,0.785 --budget_ms=0 --iterations=200 --picture=" + svg +
          " --trajectory_out=" + *dir_ + "/wind-fleet.json");
  EXPECT_EQ(r.exit_code, 3) << r.output;  // the gale is refused, the others fly
  EXPECT_THAT(r.output, HasSubstr("gale: INVALID_ARGUMENT"));
  EXPECT_THAT(r.output, HasSubstr("wind.from.speed_mps has value 40"));
  EXPECT_THAT(r.output, HasSubstr("trajectory of windy: " + *dir_ + "/wind-fleet-windy.json"));
  const std::string picture = Read(svg);
  EXPECT_THAT(picture, HasSubstr("<g class=\"wind\"><title>wind 4 m/s, from 90 deg"));
  EXPECT_THAT(picture, HasSubstr(">windy</text>"));  // the key
  // The written waypoints evaluate in the wind they were planned in.
  r = Cli("eval --wind=4@90 --trajectory_file=" + *dir_ + "/wind-fleet-windy.json");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wind 4 m/s from 90.0 deg"));
}

TEST_F(CliTest, PlanShowsProgressAndWritesPictures) {
  const std::string svg = *dir_ + "/plan.svg";
  const std::string png = *dir_ + "/plan.png";
  const std::string traj = *dir_ + "/best.json";
  // Iteration budgets: the same plan however loaded the machine (a time
  // budget could end before a slow machine finds a trajectory).
  CommandResult r =
      Cli("plan --start=300,375,240,0.785 --goal=1700,1625,250,0.785 "
          "--budget_ms=0 --iterations=600 --min_update_interval_ms=0 --tree --picture=" +
          svg + " --trajectory_out=" + traj);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("(final)"));
  EXPECT_THAT(r.output, HasSubstr("ended: BUDGET_EXHAUSTED"));
  const std::string picture = Read(svg);
  EXPECT_THAT(picture, HasSubstr("<svg"));
  EXPECT_THAT(picture, HasSubstr("data:image/png;base64,"));
  EXPECT_THAT(picture, HasSubstr("<polyline"));
  EXPECT_THAT(picture, HasSubstr("<line"));  // the tree

  // The written trajectory evaluates to the risk the plan reported.
  const size_t at = r.output.find("best: risk ");
  ASSERT_NE(at, std::string::npos);
  const double plan_risk = std::stod(r.output.substr(at + 11));
  CommandResult eval = Cli("eval --json --trajectory_file=" + traj);
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_NEAR(nlohmann::json::parse(eval.output)["risk"].get<double>(), plan_risk,
              1e-8 * plan_risk);  // printed with 9 significant digits

  r =
      Cli("plan --start=300,375,240,0.785 --goal=1700,1625,250,0.785 --budget_ms=0 "
          "--iterations=300 --picture=" +
          png);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(Read(png).substr(1, 3), "PNG");
  // The 2 km map at 5 m is 400 x 400 pixels; the caption and the legend make
  // the picture taller. The final trajectory is drawn in its dark blue, 3
  // pixels wide over about 2 km (400 pixels), and the start and goal markers
  // are there.
  int width = 0, height = 0;
  EXPECT_GT(CountPngPixels(png, 0, 40, 200, &width, &height), 3 * 300);
  EXPECT_EQ(width, 400);
  EXPECT_GT(height, 400 + 60);
  EXPECT_GT(CountPngPixels(png, 0, 170, 70, &width, &height), 100);   // start
  EXPECT_GT(CountPngPixels(png, 200, 0, 160, &width, &height), 100);  // goal
  EXPECT_GT(CountPngPixels(png, 0, 0, 0, &width, &height), 40);       // the scale bar
}

TEST_F(CliTest, PlanWithoutSolutionExitsThree) {
  CommandResult r =
      Cli("plan --start=300,375,240,0.785 --goal=1700,1625,250,0.785 "
          "--budget_ms=0 --iterations=1 --planner_params=guide_cell_m=0");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_THAT(r.output, HasSubstr("NO_SOLUTION"));
}

TEST_F(CliTest, LoadReportsThroughputLatencyAndCodes) {
  const std::string report = *dir_ + "/load.json";
  CommandResult r =
      Cli("load --rpc=eval --polyline='300,375,240; 1700,1625,250' "
          "--concurrency=2 --duration_s=1 --ceiling --report_json=" +
          report);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("vs the no-op ceiling"));
  nlohmann::json j = nlohmann::json::parse(Read(report));
  EXPECT_EQ(j["rpc"], "EvaluateRisk");
  EXPECT_EQ(j["mode"], "closed");
  // Each of the 2 callers called more than once (how many times in 1 s is
  // the machine's speed, not the generator's behaviour).
  EXPECT_GT(j["completed"].get<int>(), 2);
  EXPECT_EQ(j["codes"]["OK"], j["completed"]);
  EXPECT_GT(j["throughput_rps"].get<double>(), 0.0);
  EXPECT_GT(j["latency_ms"]["p99"].get<double>(), 0.0);
  EXPECT_LE(j["latency_ms"]["p50"].get<double>(), j["latency_ms"]["p99.9"].get<double>());
  EXPECT_EQ(j["ceiling"]["rpc"], "Ping");
  EXPECT_GT(j["ceiling"]["completed"].get<int>(), 2);
  EXPECT_GT(j["vs_ceiling"]["throughput"].get<double>(), 0.0);

  // Open loop at a fixed rate: about rate x duration calls, errors counted by code.
  r =
      Cli("load --rpc=plan --mode=open --rate=20 --duration_s=1 --budget_ms=0 --iterations=50 "
          "--start=300,375,240,0.785 --goal=1700,1625,250,0.785 --report_json=" +
          report);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = nlohmann::json::parse(Read(report));
  EXPECT_EQ(j["rpc"], "PlanTrajectory");
  EXPECT_EQ(j["sent"], 20);
  EXPECT_EQ(j["completed"], 20);
  int64_t by_code = 0;
  for (const auto& [code, n] : j["codes"].items()) by_code += n.get<int64_t>();
  EXPECT_EQ(by_code, 20);
  EXPECT_GT(j["first_update_ms"]["count"].get<int>(), 0);
}

TEST_F(CliTest, FleetShowsEachMissionASummaryAndAPictureOfAll) {
  const std::string missions = *dir_ + "/fleet.json";
  const std::string svg = *dir_ + "/fleet.svg";
  // Two missions share the goal of --goal (one tree); the third is RRT.
  std::ofstream(missions) << R"({"tenant": "ground-1", "missions": [
      {"id": "north", "start": "300,375,240,0.785", "priority": 5},
      {"id": "west", "start": [400, 300, 245, 0.785]},
      {"id": "solo", "start": "300,600,245,0.785", "algorithm": "RRT", "iterations": 200}]})";
  const std::string fleet_report = *dir_ + "/fleet-report.json";
  CommandResult r =
      Cli("fleet --missions=" + missions +
          " --goal=1700,1625,250,0.785 --budget_ms=0 --iterations=300 --picture=" + svg +
          " --report_json=" + fleet_report);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("report: " + fleet_report));
  {
    // --report_json: every mission, with the replica that planned it.
    const nlohmann::json report = nlohmann::json::parse(Read(fleet_report));
    EXPECT_EQ(report["status"], "OK");
    EXPECT_EQ(report["resubmissions"], 0);
    ASSERT_EQ(report["missions"].size(), 3u);
    const std::string port = server_->address().substr(server_->address().rfind(':'));
    std::vector<std::string> ids;
    for (const nlohmann::json& m : report["missions"]) {
      ids.push_back(m["id"].get<std::string>());
      EXPECT_THAT(m["replica"].get<std::string>(), ::testing::EndsWith("127.0.0.1" + port));
      EXPECT_EQ(m["resubmissions"], 0);
      EXPECT_GT(m["risk"].get<double>(), 0.0);
      EXPECT_GT(m["length_m"].get<double>(), 1000.0);
      // Flight time: the length at the aircraft's speed (metres per second).
      EXPECT_GT(m["flight_time_s"].get<double>(), 0.0);
      EXPECT_LT(m["flight_time_s"].get<double>(), m["length_m"].get<double>());
    }
    EXPECT_THAT(ids, ::testing::ElementsAre("north", "west", "solo"));
    EXPECT_EQ(report["missions"][2]["end"], "CONVERGED");
    EXPECT_EQ(report["missions"][0]["end"], "BUDGET_EXHAUSTED");
  }
  EXPECT_THAT(r.output, HasSubstr("fleet of 3 missions"));
  for (const char* id : {"north", "west"}) {
    EXPECT_THAT(r.output, ::testing::ContainsRegex(
                              absl::StrCat("\\[[123]/3\\] ", id, ": BUDGET_EXHAUSTED, risk ")));
  }
  EXPECT_THAT(r.output, ::testing::ContainsRegex("mission +prio +algorithm +end +risk"));
  EXPECT_THAT(r.output, ::testing::ContainsRegex("\nsolo +0 +RRT +CONVERGED"));
  const std::string picture = Read(svg);
  EXPECT_THAT(picture, HasSubstr("<title>north: risk "));
  EXPECT_THAT(picture, HasSubstr("<title>west: risk "));
  EXPECT_THAT(picture, HasSubstr("<title>solo: risk "));

  // load --rpc=fleet sends the whole fleet per call.
  const std::string report = *dir_ + "/fleet-load.json";
  r = Cli("load --rpc=fleet --missions=" + missions +
          " --goal=1700,1625,250,0.785 --budget_ms=0 --iterations=50 --concurrency=1 "
          "--duration_s=1 --report_json=" +
          report);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json j = nlohmann::json::parse(Read(report));
  EXPECT_EQ(j["rpc"], "PlanFleet");
  EXPECT_GE(j["completed"].get<int>(), 1);
  EXPECT_EQ(j["codes"]["OK"], j["completed"]);
  // Three final messages per fleet.
  EXPECT_EQ(j["plan_updates"].get<int>(), 3 * j["completed"].get<int>());
}

TEST_F(CliTest, FleetRefusesABadMissionsFileSayingWhere) {
  const std::string missions = *dir_ + "/bad-fleet.json";
  std::ofstream(missions)
      << "{\"missions\": [\n  {\"id\": \"a\", \"start\": \"300,375,240,0.785\"}\n  "
         "{\"id\": \"b\"}]}";
  CommandResult r = Cli("fleet --missions=" + missions + " --goal=1700,1625,250,0.785");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("missions file '" + missions + "': not JSON:"));
  EXPECT_THAT(r.output, HasSubstr("line 3, column 3"));

  std::ofstream(missions) << R"({"missions": [{"id": "a", "start": "300,375,240,0.785"},
      {"id": "b", "start": "300,375,240,0.785", "budget_ms": "fast"}]})";
  r = Cli("fleet --missions=" + missions + " --goal=1700,1625,250,0.785");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("missions[1].budget_ms: must be an integer"));

  std::ofstream(missions) << R"({"missions": [{"id": "a", "start": "300,375"}]})";
  r = Cli("fleet --missions=" + missions + " --goal=1700,1625,250,0.785");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("missions[0].start: "));

  r = Cli("fleet --missions=" + *dir_ + "/no-such-file.json");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("cannot open missions file"));
}

TEST_F(CliTest, ServerTakesAListOfReplicasAndSaysWhichEntryIsWrong) {
  // The same server twice and a name for it: one list, resolved and
  // de-duplicated, round-robin over what is left.
  const std::string address = server_->address();
  const std::string port = address.substr(address.rfind(':') + 1);
  const std::string tls = server_->connection().tls() ? " --tls_server_name=localhost" : "";
  CommandResult r = Cli("maps --server=" + address + ",localhost:" + port + tls);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("demo-city"));

  r = Cli("maps --server=" + address + ",,127.0.0.1:1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(": entry 2 of the list is empty"));
  r = Cli("maps --server=" + address + ",127.0.0.1:99999");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("entry 2 (\"127.0.0.1:99999\"): expected HOST:PORT with a port "
                                  "in 1..65535"));

  const std::string missions = *dir_ + "/resubmit-fleet.json";
  std::ofstream(missions) << R"({"missions": [{"id": "a", "start": "300,375,240,0.785"}]})";
  r = Cli("fleet --missions=" + missions + " --goal=1700,1625,250,0.785 --max_resubmits=11");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--max_resubmits=11: must be 0 to 10"));
}

// Two replicas behind one --server list.
class CliReplicasTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int i = 0; i < 2; ++i) {
      // One plan slot each: a fleet's missions queue on its replica.
      auto started = ServerProcess::Start({"--plan_threads=1", "--fleet_plan_slots=1",
                                           "--grace_period_ms=1000",
                                           "--metrics_listen=127.0.0.1:0"});
      ASSERT_TRUE(started.ok()) << started.status();
      servers_.push_back(*std::move(started));
    }
    char dir[] = "/tmp/riskplan-cli-replicas-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    dir_ = dir;
  }
  void TearDown() override { RunCommand("rm -rf " + dir_); }

  // The riskplan command line to both replicas (TLS as the suite's servers
  // have it: a list has no one host, so the name is given).
  std::string Riskplan(const std::string& args) const {
    std::string flags = servers_[0]->CliServerFlags();
    const std::string one = "--server=" + servers_[0]->address();
    flags.replace(flags.find(one), one.size(),
                  "--server=" + servers_[0]->address() + "," + servers_[1]->address());
    if (flags.find("--tls_ca") != std::string::npos) flags += " --tls_server_name=localhost";
    return std::string(RISKPLAN_BIN_DIR) + "/riskplan " + flags + " " + args;
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  static std::string Port(const ServerProcess& s) {
    return s.address().substr(s.address().rfind(':') + 1);
  }

  std::vector<std::unique_ptr<ServerProcess>> servers_;
  std::string dir_;
};

// A replica that drains mid-fleet: the CLI says which replica, that it was
// draining, which missions it sends again and to which replica they went;
// the report names each mission's replica and re-submissions.
TEST_F(CliReplicasTest, FleetSaysWhichReplicaDrainedAndWhereItsMissionsWent) {
  const std::string missions = dir_ + "/fleet.json";
  // Each its own goal: one plan slot takes one goal's group at a time, so
  // three wait in the queue when the drain comes.
  std::ofstream(missions) << R"({"missions": [
      {"id": "a", "goal": "1700,1625,250,0.785"}, {"id": "b", "goal": "1600,1700,250,0.785"},
      {"id": "c", "goal": "1750,1500,250,0.785"}, {"id": "d", "goal": "1650,1600,250,0.785"}]})";
  const std::string report = dir_ + "/fleet-report.json";
  CommandResult r;
  std::thread cli([&] {
    r = RunCommand(Riskplan("fleet --missions=" + missions +
                            " --start=300,375,240,0.785 --budget_ms=3000 --report_json=" +
                            report + " 2>&1"),
                   absl::Minutes(3));
  });
  // The replica the fleet went to: the one whose metrics show its missions.
  int busy = -1;
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  while (busy < 0 && absl::Now() < deadline) {
    for (int i = 0; i < 2 && busy < 0; ++i) {
      absl::StatusOr<std::string> text =
          HttpGet(MetricsAddress(servers_[i]->Stderr()), "/metrics");
      if (!text.ok()) continue;
      const double held =
          MetricValue(*text, "riskplan_fleet_missions{state=\"queued\"}").value_or(0) +
          MetricValue(*text, "riskplan_fleet_missions{state=\"running\"}").value_or(0);
      if (held >= 4) busy = i;
    }
    if (busy < 0) absl::SleepFor(absl::Milliseconds(20));
  }
  if (busy >= 0) servers_[busy]->Signal(SIGTERM);
  cli.join();
  ASSERT_GE(busy, 0) << "the fleet never reached a replica: " << r.output;
  const std::string drained = Port(*servers_[busy]);
  const std::string other = Port(*servers_[1 - busy]);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, ::testing::ContainsRegex(
                            "riskplan: replica ipv4:127.0.0.1:" + drained +
                            " was draining \\(shutting down\\): it ended PlanFleet OK with [1-4] "
                            "missions unplanned \\([a-d](, [a-d])*\\); sending them again to "
                            "another replica \\(re-submission 1\\)"));
  EXPECT_THAT(r.output, ::testing::ContainsRegex("riskplan: re-submission 1 went to replica "
                                                 "ipv4:127.0.0.1:" +
                                                 other + ": [1-4] missions, [1-4] ended there "
                                                         "\\(OK\\)"));
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("()")));
  const nlohmann::json j = nlohmann::json::parse(Read(report));
  EXPECT_EQ(j["resubmissions"], 1);
  int moved = 0;
  for (const nlohmann::json& m : j["missions"]) {
    const std::string replica = m["replica"].get<std::string>();
    if (m["resubmissions"] == 1) {
      ++moved;
      EXPECT_EQ(replica, "ipv4:127.0.0.1:" + other) << m.dump();
    } else {
      EXPECT_EQ(replica, "ipv4:127.0.0.1:" + drained) << m.dump();
    }
    EXPECT_FALSE(m["risk"].is_null()) << m.dump();
  }
  EXPECT_GE(moved, 1);
}

// `riskplan load` over a list reports each replica's calls.
TEST_F(CliReplicasTest, LoadReportsEachReplicasCalls) {
  const std::string report = dir_ + "/load.json";
  CommandResult r = RunCommand(
      Riskplan("load --rpc=ping --concurrency=4 --duration_s=1 --report_json=" + report + " 2>&1"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(Read(report));
  ASSERT_EQ(j["replicas"].size(), 2u) << j.dump();
  int64_t total = 0;
  for (const auto& server : servers_) {
    const std::string peer = "ipv4:127.0.0.1:" + Port(*server);
    ASSERT_TRUE(j["replicas"].contains(peer)) << j.dump();
    EXPECT_GT(j["replicas"][peer]["completed"].get<int64_t>(), 0);
    EXPECT_EQ(j["replicas"][peer]["codes"]["OK"], j["replicas"][peer]["completed"]);
    total += j["replicas"][peer]["completed"].get<int64_t>();
    EXPECT_THAT(r.output, ::testing::ContainsRegex("replica " + peer + ": [0-9]+ calls: OK="));
  }
  EXPECT_EQ(total, j["completed"].get<int64_t>());
}

}  // namespace
}  // namespace riskplan::testing
