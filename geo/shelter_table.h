// Land-cover classes to shelter factors (risk model: 0 open ground ... 10
// industrial buildings), and which classes are open fields a UAV may land on.
// The default tables and the reasons for their values are in docs/geodata.md.
#ifndef RISKPLAN_GEO_SHELTER_TABLE_H_
#define RISKPLAN_GEO_SHELTER_TABLE_H_

#include <map>
#include <string>

#include "absl/status/statusor.h"

namespace riskplan::geo {

struct ClassRule {
  double shelter = 0.0;  // [0, 10]
  bool landing = false;  // an open field: a candidate emergency landing site
  std::string label;     // e.g. "Grassland"; may be empty
};

struct ShelterTable {
  std::string name;                // "worldcover", "corine", or a file's path
  std::map<int, ClassRule> rules;  // by class value
};

// ESA WorldCover 10 m (2020 v100, 2021 v200): classes 10 ... 100.
ShelterTable WorldCoverTable();
// CORINE Land Cover (CLC 2000-2018): both the three-digit codes (111 ... 523)
// of the vector product and the raster product's pixel values (1 ... 44,
// in the order of the codes; 48 is its nodata and has no rule).
ShelterTable CorineTable();

// The table named `name` ("worldcover" or "corine"), or InvalidArgument
// listing the names.
absl::StatusOr<ShelterTable> DefaultShelterTable(const std::string& name);

// Applies the rules of a small text file on top of `table` (adding or
// replacing classes): one rule per line, `CLASS SHELTER [landing] [# label]`,
// e.g. `30 0.5 landing # grass`; blank lines and lines starting with '#'
// are ignored. InvalidArgument names the file, the line and what is wrong
// (a class that is not an integer, a shelter outside [0, 10], an unknown
// word); NotFound if the file cannot be read. At most 64 KiB.
absl::Status ApplyShelterFile(const std::string& path, ShelterTable* table);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_SHELTER_TABLE_H_
