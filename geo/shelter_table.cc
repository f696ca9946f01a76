#include "geo/shelter_table.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace riskplan::geo {
namespace {

// The shelter scale of the risk model (Dalamagkidis et al.'s sheltering
// parameter): 0 no obstacle, 2.5 sparse trees, 5 low buildings, 7.5 high
// buildings, 10 industrial buildings.
constexpr double kOpen = 0.0;
constexpr double kSparseTrees = 2.5;
constexpr double kLowBuildings = 5.0;
constexpr double kHighBuildings = 7.5;
constexpr double kIndustrial = 10.0;

constexpr size_t kMaxFileBytes = 64 * 1024;

struct CorineClass {
  int code;
  double shelter;
  bool landing;
  const char* label;
};

// In code order: the raster product's pixel value is the 1-based position.
constexpr CorineClass kCorine[] = {
    {111, kHighBuildings, false, "Continuous urban fabric"},
    {112, kLowBuildings, false, "Discontinuous urban fabric"},
    {121, kIndustrial, false, "Industrial or commercial units"},
    {122, kOpen, false, "Road and rail networks"},
    {123, kHighBuildings, false, "Port areas"},
    {124, kOpen, false, "Airports"},
    {131, kOpen, false, "Mineral extraction sites"},
    {132, kOpen, false, "Dump sites"},
    {133, kSparseTrees, false, "Construction sites"},
    {141, kSparseTrees, false, "Green urban areas"},
    {142, kOpen, true, "Sport and leisure facilities"},
    {211, kOpen, true, "Non-irrigated arable land"},
    {212, kOpen, true, "Permanently irrigated land"},
    {213, kOpen, false, "Rice fields"},
    {221, kSparseTrees, false, "Vineyards"},
    {222, kSparseTrees, false, "Fruit trees and berry plantations"},
    {223, kSparseTrees, false, "Olive groves"},
    {231, kOpen, true, "Pastures"},
    {241, kOpen, true, "Annual crops associated with permanent crops"},
    {242, kSparseTrees, false, "Complex cultivation patterns"},
    {243, kSparseTrees, false, "Agriculture with significant natural vegetation"},
    {244, kSparseTrees, false, "Agro-forestry areas"},
    {311, kLowBuildings, false, "Broad-leaved forest"},
    {312, kLowBuildings, false, "Coniferous forest"},
    {313, kLowBuildings, false, "Mixed forest"},
    {321, kOpen, true, "Natural grasslands"},
    {322, kOpen, true, "Moors and heathland"},
    {323, kSparseTrees, false, "Sclerophyllous vegetation"},
    {324, kSparseTrees, false, "Transitional woodland-shrub"},
    {331, kOpen, true, "Beaches, dunes, sands"},
    {332, kOpen, false, "Bare rocks"},
    {333, kOpen, true, "Sparsely vegetated areas"},
    {334, kOpen, false, "Burnt areas"},
    {335, kOpen, false, "Glaciers and perpetual snow"},
    {411, kOpen, false, "Inland marshes"},
    {412, kOpen, false, "Peat bogs"},
    {421, kOpen, false, "Salt marshes"},
    {422, kOpen, false, "Salines"},
    {423, kOpen, false, "Intertidal flats"},
    {511, kOpen, false, "Water courses"},
    {512, kOpen, false, "Water bodies"},
    {521, kOpen, false, "Coastal lagoons"},
    {522, kOpen, false, "Estuaries"},
    {523, kOpen, false, "Sea and ocean"},
};

}  // namespace

ShelterTable WorldCoverTable() {
  ShelterTable t;
  t.name = "worldcover";
  t.rules = {
      {10, {kLowBuildings, false, "Tree cover"}}, {20, {kSparseTrees, false, "Shrubland"}},
      {30, {kOpen, true, "Grassland"}},           {40, {kOpen, true, "Cropland"}},
      {50, {kLowBuildings, false, "Built-up"}},   {60, {kOpen, true, "Bare / sparse vegetation"}},
      {70, {kOpen, false, "Snow and ice"}},       {80, {kOpen, false, "Permanent water bodies"}},
      {90, {kOpen, false, "Herbaceous wetland"}}, {95, {kSparseTrees, false, "Mangroves"}},
      {100, {kOpen, true, "Moss and lichen"}},
  };
  return t;
}

ShelterTable CorineTable() {
  ShelterTable t;
  t.name = "corine";
  // Both the raster product's pixel values (1-44) and the vector product's
  // codes (111-523) are known: the two do not overlap.
  int index = 1;
  for (const CorineClass& c : kCorine) {
    t.rules[c.code] = {c.shelter, c.landing, c.label};
    t.rules[index++] = {c.shelter, c.landing, c.label};
  }
  return t;
}

absl::StatusOr<ShelterTable> DefaultShelterTable(const std::string& name) {
  if (name == "worldcover") return WorldCoverTable();
  if (name == "corine") return CorineTable();
  return absl::InvalidArgumentError(absl::StrFormat(
      "land-cover classes '%s' are not known; use worldcover or corine (and a shelter table "
      "file for others)",
      name));
}

absl::Status ApplyShelterFile(const std::string& path, ShelterTable* table) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrFormat("shelter table '%s': cannot read it", path));
  // One byte more than the limit is read, to tell a file of exactly the
  // limit from a larger one.
  std::string text(kMaxFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  if (text.size() > kMaxFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrFormat("shelter table '%s': larger than %d bytes", path, kMaxFileBytes));
  }
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    std::string label;
    if (const size_t hash = line.find('#'); hash != absl::string_view::npos) {
      label = std::string(absl::StripAsciiWhitespace(line.substr(hash + 1)));
      line = line.substr(0, hash);
    }
    // '\r' among the separators: a file with CRLF line ends reads the same.
    std::vector<absl::string_view> words =
        absl::StrSplit(line, absl::ByAnyChar(" \t\r,;"), absl::SkipEmpty());
    if (words.empty()) continue;
    auto bad = [&](const std::string& what) {
      return absl::InvalidArgumentError(
          absl::StrFormat("shelter table '%s', line %d: %s", path, line_number, what));
    };
    int64_t cls = 0;
    if (!absl::SimpleAtoi(words[0], &cls) || cls < INT32_MIN || cls > INT32_MAX) {
      return bad(absl::StrFormat("class '%s' is not an integer", words[0]));
    }
    double shelter = 0.0;
    if (words.size() < 2 || !absl::SimpleAtod(words[1], &shelter) || !std::isfinite(shelter) ||
        shelter < 0.0 || shelter > 10.0) {
      return bad(
          absl::StrFormat("class %d needs a shelter factor in [0, 10]; expected 'CLASS "
                          "SHELTER [landing]'",
                          cls));
    }
    bool landing = false;
    for (size_t k = 2; k < words.size(); ++k) {
      const std::string word = absl::AsciiStrToLower(words[k]);
      if (word == "landing") {
        landing = true;
      } else if (word != "-") {
        return bad(
            absl::StrFormat("unknown word '%s' (only 'landing' may follow the shelter)", words[k]));
      }
    }
    table->rules[static_cast<int>(cls)] = {shelter, landing, label};
  }
  table->name = absl::StrFormat("%s + %s", table->name, path);
  return absl::OkStatus();
}

}  // namespace riskplan::geo
