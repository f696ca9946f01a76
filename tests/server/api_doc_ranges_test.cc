// The documented ranges of every model and planner parameter are the ones the
// server checks: each table of docs/api.md, docs/risk-model.md and
// docs/planners.md is read and compared with ModelParamRanges() and
// PlannerParams(), name by name, so that the two cannot drift apart.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "core/base/model_params.h"
#include "core/planners/planner.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

constexpr PlannerAlgorithm kAlgorithms[] = {PlannerAlgorithm::kRiskRrtStar, PlannerAlgorithm::kRrt,
                                            PlannerAlgorithm::kGenetic,
                                            PlannerAlgorithm::kHarmonic};

// One row of a `| name | default | range | ... |` table.
struct Row {
  std::string name;
  std::optional<double> default_value;  // when the cell starts with a number
  double min_value = 0.0;
  double max_value = 0.0;
  int line = 0;
};

// A table, and the algorithm whose section it is in ("" when none).
struct Table {
  std::string algorithm;
  std::vector<Row> rows;
};

std::string ReadDoc(const std::string& name) {
  std::ifstream in(std::string(RISKPLAN_SOURCE_DIR) + "/docs/" + name);
  EXPECT_TRUE(in.good()) << name;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The cell without spaces and backticks.
std::string Trim(absl::string_view s) {
  return std::string(absl::StripAsciiWhitespace(
      absl::StripPrefix(absl::StripSuffix(absl::StripAsciiWhitespace(s), "`"), "`")));
}

// The leading number of a cell ("0 (= 2.5 · step_m)" is 0), if any.
std::optional<double> LeadingNumber(const std::string& cell) {
  const char* begin = cell.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end == begin) return std::nullopt;
  return v;
}

// "[lo, hi]" at the start of a cell (text may follow: ", whole").
bool ParseRange(const std::string& cell, double* lo, double* hi) {
  if (cell.empty() || cell[0] != '[') return false;
  const size_t close = cell.find(']');
  if (close == std::string::npos) return false;
  std::vector<std::string> parts = absl::StrSplit(cell.substr(1, close - 1), ',');
  if (parts.size() != 2) return false;
  const std::optional<double> a = LeadingNumber(Trim(parts[0]));
  const std::optional<double> b = LeadingNumber(Trim(parts[1]));
  if (!a || !b) return false;
  *lo = *a;
  *hi = *b;
  return true;
}

// Every table whose header is `| name | default | <range column> | ...`,
// with the algorithm of the last heading (`#...` or `**...**`) whose first
// word names one.
std::vector<Table> ParseTables(const std::string& text, const std::string& doc) {
  std::set<std::string> algorithms;
  for (PlannerAlgorithm a : kAlgorithms) algorithms.insert(std::string(PlannerAlgorithmName(a)));
  std::vector<Table> tables;
  std::string algorithm;
  bool in_table = false;
  int line_number = 0;
  const std::vector<std::string> lines = absl::StrSplit(text, '\n');
  for (const std::string& line : lines) {
    ++line_number;
    if (absl::StartsWith(line, "#") || absl::StartsWith(line, "**")) {
      const size_t start = line.find_first_not_of("#* ");
      if (start != std::string::npos) {
        const std::string heading = line.substr(start);
        const std::string first = heading.substr(0, heading.find_first_of(" *("));
        if (algorithms.count(first) > 0) algorithm = first;
      }
    }
    if (!absl::StartsWith(line, "|")) {
      in_table = false;
      continue;
    }
    std::vector<std::string> cells = absl::StrSplit(line, '|');
    // "| a | b |" splits into "", " a ", " b ", "".
    if (cells.size() < 5) continue;
    const std::string first = Trim(cells[1]);
    if (first == "name" && Trim(cells[2]) == "default") {
      in_table = true;
      tables.push_back(Table{algorithm, {}});
      continue;
    }
    if (!in_table || absl::StartsWith(first, "---")) continue;
    Row row;
    row.name = first;
    row.line = line_number;
    row.default_value = LeadingNumber(Trim(cells[2]));
    EXPECT_TRUE(ParseRange(Trim(cells[3]), &row.min_value, &row.max_value))
        << doc << ":" << line_number << ": no [min, max] in '" << cells[3] << "'";
    tables.back().rows.push_back(row);
  }
  return tables;
}

void ExpectClose(double documented, double code, const std::string& what) {
  // Documents print %g (six significant digits).
  EXPECT_NEAR(documented, code, 1e-5 * std::max(1.0, std::fabs(code))) << what;
}

// The model-parameter table of `doc` (the one whose names are model
// parameters) against ModelParamRanges().
void CheckModelTable(const std::string& doc, bool check_defaults) {
  const std::vector<Table> tables = ParseTables(ReadDoc(doc), doc);
  const std::vector<ModelParamRange>& ranges = ModelParamRanges();
  const Table* model_table = nullptr;
  for (const Table& t : tables) {
    if (!t.rows.empty() && t.rows.front().name == ranges.front().name) model_table = &t;
  }
  ASSERT_NE(model_table, nullptr) << doc << " has no model-parameter table";
  ASSERT_EQ(model_table->rows.size(), ranges.size()) << doc;
  for (size_t i = 0; i < ranges.size(); ++i) {
    const Row& row = model_table->rows[i];
    const ModelParamRange& r = ranges[i];
    const std::string where = doc + ":" + std::to_string(row.line) + " " + row.name;
    EXPECT_EQ(row.name, r.name) << where;
    ExpectClose(row.min_value, r.min_value, where + " min");
    ExpectClose(row.max_value, r.max_value, where + " max");
    if (check_defaults) {
      ASSERT_TRUE(row.default_value.has_value()) << where;
      ExpectClose(*row.default_value, *GetModelParam(ModelParams{}, r.name), where + " default");
    }
  }
}

// Every algorithm's table of `doc` against PlannerParams(algorithm).
void CheckPlannerTables(const std::string& doc) {
  const std::vector<Table> tables = ParseTables(ReadDoc(doc), doc);
  for (PlannerAlgorithm algorithm : kAlgorithms) {
    const std::string name(PlannerAlgorithmName(algorithm));
    const std::vector<PlannerParamInfo>& infos = PlannerParams(algorithm);
    const Table* table = nullptr;
    for (const Table& t : tables) {
      if (t.algorithm == name && !t.rows.empty()) table = &t;
    }
    ASSERT_NE(table, nullptr) << doc << " has no table for " << name;
    std::map<std::string, const Row*> rows;
    for (const Row& row : table->rows) rows[row.name] = &row;
    EXPECT_EQ(rows.size(), infos.size()) << doc << " " << name << ": parameters documented";
    for (const PlannerParamInfo& info : infos) {
      const std::string where = doc + " " + name + " " + info.name;
      auto it = rows.find(info.name);
      if (it == rows.end()) {
        ADD_FAILURE() << where << " is not documented";
        continue;
      }
      const Row& row = *it->second;
      ExpectClose(row.min_value, info.min_value, where + " min");
      ExpectClose(row.max_value, info.max_value, where + " max");
      ASSERT_TRUE(row.default_value.has_value()) << where;
      ExpectClose(*row.default_value, info.default_value, where + " default");
    }
  }
}

TEST(ApiDocRangesTest, ModelParameterTablesAreTheCodes) {
  CheckModelTable("api.md", /*check_defaults=*/true);
  // risk-model.md writes some defaults as the spec does (5e-3/3600).
  CheckModelTable("risk-model.md", /*check_defaults=*/false);
}

TEST(ApiDocRangesTest, PlannerParameterTablesAreTheCodes) {
  CheckPlannerTables("api.md");
  CheckPlannerTables("planners.md");
}

// common.proto documents each field of ModelParameters as
// `// [default] unit, [min, max] ...`.
TEST(ApiDocRangesTest, TheProtoCommentsAreTheCodes) {
  std::ifstream in(std::string(RISKPLAN_SOURCE_DIR) + "/proto/riskplan/v1/common.proto");
  ASSERT_TRUE(in.good());
  std::stringstream text;
  text << in.rdbuf();
  const std::regex field(
      R"(optional (?:double|int32) (\w+) = \d+;\s*// \[([^\]]+)\][^\[]*(\[[^\]]+\]))");
  std::map<std::string, Row> rows;
  const std::vector<std::string> lines = absl::StrSplit(text.str(), '\n');
  for (const std::string& line : lines) {
    std::smatch m;
    if (!std::regex_search(line, m, field)) continue;
    Row row;
    row.name = m[1];
    EXPECT_TRUE(ParseRange(m[3], &row.min_value, &row.max_value)) << line;
    rows[row.name] = row;
  }
  ASSERT_EQ(rows.size(), ModelParamRanges().size());
  for (const ModelParamRange& r : ModelParamRanges()) {
    auto it = rows.find(std::string(r.name));
    ASSERT_NE(it, rows.end()) << r.name;
    ExpectClose(it->second.min_value, r.min_value, std::string(r.name) + " min");
    ExpectClose(it->second.max_value, r.max_value, std::string(r.name) + " max");
  }
}

}  // namespace
}  // namespace riskplan
