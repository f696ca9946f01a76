// riskplan-tool's trajectory JSON reader against the shared table of cases,
// tests/data/trajectory_json_cases.json, which the CLI client's reader
// (tests/client/trajectory_text_test.cc) is tested against too: one rule,
// two implementations, one table.
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
#include "nlohmann/json.hpp"

namespace riskplan {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using Json = nlohmann::json;
using Points = std::vector<std::vector<double>>;

// One entry of the table, as the table's "about" describes it.
struct Case {
  std::string name;
  std::string text;  // the JSON text, or the file's content
  // File cases: how the file is made when it is not `text`.
  bool missing = false;
  bool directory = false;
  int64_t size = -1;  // a file of this many zero bytes
  // The outcome: an error, or the kind and the points read.
  std::string error;
  std::string code;
  std::string kind;  // "waypoints" or "polyline"
  Points points;
};

Json LoadTable() {
  const std::string path =
      std::string(RISKPLAN_SOURCE_DIR) + "/tests/data/trajectory_json_cases.json";
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot open " << path;
  return Json::parse(in);  // a broken table throws, and the test fails
}

Case ReadCase(const Json& entry) {
  Case c;
  c.name = entry.at("name").get<std::string>();
  int inputs = 0;
  if (entry.contains("text")) {
    c.text = entry["text"].get<std::string>();
    ++inputs;
  }
  if (entry.contains("json")) {
    c.text = entry["json"].dump();
    ++inputs;
  }
  Points repeated;
  if (entry.contains("repeat")) {
    const Json& r = entry["repeat"];
    const int64_t count = r.at("count").get<int64_t>();
    Json doc = {{r.at("key").get<std::string>(), Json::array()}};
    Json& list = doc[r["key"].get<std::string>()];
    for (int64_t i = 0; i < count; ++i) list.push_back(r.at("point"));
    repeated.assign(count, r["point"].get<std::vector<double>>());
    c.text = doc.dump();
    ++inputs;
  }
  if (entry.contains("size")) {
    c.size = entry["size"].get<int64_t>();
    ++inputs;
  }
  c.missing = entry.value("missing", false);
  c.directory = entry.value("directory", false);
  inputs += c.missing + c.directory;
  EXPECT_EQ(inputs, 1) << c.name << ": give exactly one input";

  int outcomes = 0;
  if (entry.contains("error")) {
    c.error = entry["error"].get<std::string>();
    c.code = entry.value("code", "INVALID_ARGUMENT");
    ++outcomes;
  }
  for (const char* kind : {"waypoints", "polyline"}) {
    if (!entry.contains(kind)) continue;
    c.kind = kind;
    c.points = entry[kind] == "repeated" ? repeated : entry[kind].get<Points>();
    ++outcomes;
  }
  EXPECT_EQ(outcomes, 1) << c.name << ": give exactly one outcome";
  return c;
}

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
    const std::string path = (dir / ("case" + std::to_string(n++) + ".json")).string();
    if (c.directory) {
      std::filesystem::create_directory(path);
    } else if (c.size >= 0) {
      std::ofstream(path).close();
      std::filesystem::resize_file(path, c.size);  // sparse: costs no disk
    } else if (!c.missing) {
      std::ofstream(path, std::ios::binary) << c.text;
    }
    ExpectOutcome(c, ReadTrajectoryFile(path), path);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace riskplan
