// The shared table of trajectory JSON cases, tests/data/trajectory_json_cases.json:
// one rule, parsed once (formats/trajectory_json.h), behind two adapters
// (core/flight/trajectory_io.h for riskplan-tool, client/trajectory_text.h for
// the CLI), both tested against this one table by
// tests/core/flight/trajectory_io_test.cc and tests/client/trajectory_text_test.cc.
#ifndef RISKPLAN_TESTS_TRAJECTORY_JSON_CASES_H_
#define RISKPLAN_TESTS_TRAJECTORY_JSON_CASES_H_

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"

namespace riskplan::trajectory_json_cases {

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

inline Json LoadTable() {
  const std::string path =
      std::string(RISKPLAN_SOURCE_DIR) + "/tests/data/trajectory_json_cases.json";
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot open " << path;
  return Json::parse(in);  // a broken table throws, and the test fails
}

inline Case ReadCase(const Json& entry) {
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

// Makes file case number `n` in `dir` (a directory, a sparse file of c.size
// zero bytes, the case's text, or nothing for a missing file) and returns its
// path.
inline std::string MakeCaseFile(const std::filesystem::path& dir, int n, const Case& c) {
  const std::string path = (dir / ("case" + std::to_string(n) + ".json")).string();
  if (c.directory) {
    std::filesystem::create_directory(path);
  } else if (c.size >= 0) {
    std::ofstream(path).close();
    std::filesystem::resize_file(path, c.size);  // sparse: costs no disk
  } else if (!c.missing) {
    std::ofstream(path, std::ios::binary) << c.text;
  }
  return path;
}

}  // namespace riskplan::trajectory_json_cases

#endif  // RISKPLAN_TESTS_TRAJECTORY_JSON_CASES_H_
