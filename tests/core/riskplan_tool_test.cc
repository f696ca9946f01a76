// riskplan-tool end to end: the real binary on a bundle it wrote itself.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/map_bundle.h"
#include "core/risk_model.h"
#include "core/trajectory.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"

namespace riskplan {
namespace {

using ::testing::HasSubstr;

struct Output {
  int exit_code = -1;
  std::string text;  // stdout and stderr
};

Output RunTool(const std::string& args) {
  const std::string command = std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool " + args + " 2>&1";
  Output out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return out;
  char buffer[4096];
  size_t n = 0;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) out.text.append(buffer, n);
  const int status = pclose(pipe);
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

class RiskplanToolTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One directory per process: CTest runs the tests of this file in parallel.
    dir_ =
        new std::string(::testing::TempDir() + "/riskplan_tool_test." + std::to_string(getpid()));
    std::filesystem::remove_all(*dir_);
    std::filesystem::create_directories(*dir_);
    const Output written = RunTool("write-map --out=" + *dir_ + "/city --size_m=1000 --res_m=10");
    ASSERT_EQ(written.exit_code, 0) << written.text;
    ASSERT_THAT(written.text, HasSubstr("wrote demo-city (100 x 100 cells"));
  }
  static std::string* dir_;
};
std::string* RiskplanToolTest::dir_ = nullptr;

TEST_F(RiskplanToolTest, InfoDescribesTheBundle) {
  const Output out = RunTool("info --map=" + *dir_ + "/city");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("100 x 100 cells of 10 m"));
  EXPECT_THAT(out.text, HasSubstr("demo-city"));
}

TEST_F(RiskplanToolTest, EvaluatePrintsWhatTheLibraryComputes) {
  auto map = LoadMapBundle(*dir_ + "/city");
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  int i = 0;
  int j = 0;
  ASSERT_TRUE((*map)->CellOf(300, 300, &i, &j));
  const double z = (*model)->SafeAltitude(i, j) + 20.0;
  const std::string polyline = "300,300," + std::to_string(z) + ";700,650," + std::to_string(z);
  const Output out =
      RunTool("evaluate --json --samples --map=" + *dir_ + "/city --polyline='" + polyline + "'");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  const nlohmann::json doc = nlohmann::json::parse(out.text);
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{300, 300, z}, {700, 650, z}});
  ASSERT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(**model, *pieces, {.keep_samples = true});
  ASSERT_TRUE(eval.ok());
  EXPECT_EQ(doc["risk"].get<double>(), eval->risk);  // JSON round-trips doubles exactly
  EXPECT_EQ(doc["length_m"].get<double>(), eval->length_m);
  EXPECT_EQ(doc["admissible"].get<bool>(), eval->admissible);
  ASSERT_EQ(doc["samples"].size(), eval->samples.size());
  EXPECT_EQ(doc["samples"][7]["M"].get<double>(), eval->samples[7].risk.risk);
  EXPECT_EQ(doc["samples"][7]["arc_length_m"].get<double>(), eval->samples[7].arc_length_m);

  const Output text = RunTool("evaluate --map=" + *dir_ + "/city --waypoints='300,300," +
                              std::to_string(z) + ",0; 700,650," + std::to_string(z) + ",1.2'");
  ASSERT_EQ(text.exit_code, 0) << text.text;
  EXPECT_THAT(text.text, HasSubstr("1 Dubins-airplane pieces"));
  EXPECT_THAT(text.text, HasSubstr("admissible"));
}

TEST_F(RiskplanToolTest, EvaluateReportsTheFirstViolation) {
  const Output out =
      RunTool("evaluate --map=" + *dir_ + "/city --polyline='500,500,50;600,500,50'");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("admissible  no"));
  EXPECT_THAT(out.text, HasSubstr("TERRAIN_COLLISION at (500.0, 500.0, 50.0) m, arc length 0.0 m"));
}

TEST_F(RiskplanToolTest, BadInputGetsAClearErrorAndExitCode2) {
  Output out = RunTool("evaluate --polyline='1,2,3;4,5,6' --waypoints='1,2,3,4;5,6,7,8'");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text,
              HasSubstr("give exactly one of --waypoints, --polyline and --trajectory_file"));
  out = RunTool("evaluate --map=" + *dir_ + "/city --polyline='1,2,3;4,x,6'");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("polyline[1]: 'x' is not a number"));
  out = RunTool("evaluate --map=" + *dir_ + "/city --params=mass_kg=-3 --polyline='1,2,3;4,5,6'");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("mass_kg"));
  out = RunTool("evaluate --map=" + *dir_ + "/nowhere --polyline='1,2,3;4,5,6'");
  EXPECT_NE(out.exit_code, 0);
  EXPECT_THAT(out.text, HasSubstr("nowhere"));
  out = RunTool("frobnicate");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("unknown command 'frobnicate'"));
}

TEST_F(RiskplanToolTest, RiskLayerWritesAHeatMapAndAGrid) {
  const std::string prefix = *dir_ + "/layer";
  const Output out =
      RunTool("risk-layer --map=" + *dir_ + "/city --out=" + prefix + " --agl_m=90 --threads=2");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("100 x 100 cells at 90 m AGL"));
  std::ifstream png(prefix + ".png", std::ios::binary);
  char signature[8] = {};
  png.read(signature, 8);
  EXPECT_EQ(std::string(signature + 1, 3), "PNG");
  std::ifstream asc(prefix + ".asc");
  std::string key;
  int value = 0;
  asc >> key >> value;
  EXPECT_EQ(key, "ncols");
  EXPECT_EQ(value, 100);
  const Output bad =
      RunTool("risk-layer --map=" + *dir_ + "/city --out=" + prefix + " --heading_deg=north");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.text, HasSubstr("'north' is neither a number of degrees nor 'max'"));
}

}  // namespace
}  // namespace riskplan
