// riskplan-tool's trajectory JSON reader against the shared table of cases,
// tests/data/trajectory_json_cases.json, which the CLI client's reader
// (tests/client/trajectory_text_test.cc) is tested against too: one rule
// (formats/trajectory_json.h), two adapters, one table.
#include "core/flight/trajectory_io.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_replace.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/trajectory_json_cases.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using trajectory_json_cases::Case;
using trajectory_json_cases::Json;
using trajectory_json_cases::LoadTable;
using trajectory_json_cases::MakeCaseFile;
using trajectory_json_cases::Points;
using trajectory_json_cases::ReadCase;

// The parsed trajectory as the table writes it; `kind` is "" when neither or
// both kinds were set.
void Flatten(const TrajectoryInput& input, std::string* kind, Points* points) {
  points->clear();
  for (const Pose& p : input.waypoints) points->push_back({p.x, p.y, p.z, p.theta});
  for (const Point3& p : input.polyline) points->push_back({p.x, p.y, p.z});
  *kind = input.waypoints.empty() == input.polyline.empty() ? ""
          : input.is_polyline()                             ? "polyline"
                                                            : "waypoints";
}

void ExpectOutcome(const Case& c, const absl::StatusOr<TrajectoryInput>& got,
                   const std::string& path) {
  if (!c.error.empty()) {
    ASSERT_FALSE(got.ok()) << "accepted; expected: " << c.error;
    EXPECT_EQ(absl::StatusCodeToString(got.status().code()), c.code) << got.status();
    EXPECT_THAT(std::string(got.status().message()),
                HasSubstr(absl::StrReplaceAll(c.error, {{"{path}", path}})));
    return;
  }
  ASSERT_TRUE(got.ok()) << got.status();
  std::string kind;
  Points points;
  Flatten(*got, &kind, &points);
  EXPECT_EQ(kind, c.kind);
  EXPECT_EQ(points.size(), c.points.size());
  EXPECT_TRUE(points == c.points) << "the points read differ from the table's";
}

TEST(TrajectoryIoTest, JsonTextFollowsTheSharedTable) {
  const Json table = LoadTable();
  ASSERT_GE(table.at("cases").size(), 40u);
  for (const Json& entry : table["cases"]) {
    const Case c = ReadCase(entry);
    SCOPED_TRACE(c.name);
    const absl::StatusOr<TrajectoryInput> got = ParseTrajectoryJson(c.text);
    ExpectOutcome(c, got, "");
    if (!got.ok()) {
      EXPECT_THAT(std::string(got.status().message()), StartsWith("trajectory JSON: "));
    }
  }
}

TEST(TrajectoryIoTest, JsonFilesFollowTheSharedTable) {
  const Json table = LoadTable();
  ASSERT_GE(table.at("file_cases").size(), 7u);
  const std::filesystem::path dir =
      ::testing::TempDir() + "trajectory_io_test." + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  int n = 0;
  for (const Json& entry : table["file_cases"]) {
    const Case c = ReadCase(entry);
    SCOPED_TRACE(c.name);
    const std::string path = MakeCaseFile(dir, n++, c);
    ExpectOutcome(c, ReadTrajectoryFile(path), path);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace riskplan
