#include "geo/shelter_table.h"

#include <fstream>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/geo/geodata_fixtures.h"

namespace riskplan::geo {
namespace {

using ::testing::HasSubstr;

TEST(ShelterTableTest, WorldCoverDefaults) {
  const ShelterTable t = WorldCoverTable();
  EXPECT_EQ(t.rules.size(), 11u);
  EXPECT_EQ(t.rules.at(50).shelter, 5.0);  // built-up
  EXPECT_EQ(t.rules.at(30).shelter, 0.0);  // grassland
  EXPECT_TRUE(t.rules.at(30).landing);
  EXPECT_TRUE(t.rules.at(40).landing);   // cropland
  EXPECT_FALSE(t.rules.at(80).landing);  // water
  EXPECT_FALSE(t.rules.at(10).landing);  // trees
  EXPECT_FALSE(t.rules.contains(0));     // WorldCover's nodata
  for (const auto& [cls, rule] : t.rules) {
    EXPECT_GE(rule.shelter, 0.0) << cls;
    EXPECT_LE(rule.shelter, 10.0) << cls;
  }
}

TEST(ShelterTableTest, CorineHasCodesAndRasterValues) {
  const ShelterTable t = CorineTable();
  EXPECT_EQ(t.rules.size(), 88u);            // 44 codes and 44 raster values
  EXPECT_EQ(t.rules.at(121).shelter, 10.0);  // industrial or commercial units
  EXPECT_EQ(t.rules.at(3).shelter, 10.0);    // its raster value
  EXPECT_EQ(t.rules.at(111).shelter, 7.5);
  EXPECT_EQ(t.rules.at(1).shelter, 7.5);
  EXPECT_TRUE(t.rules.at(231).landing);  // pastures
  EXPECT_TRUE(t.rules.at(18).landing);
  EXPECT_EQ(t.rules.at(523).label, "Sea and ocean");
  EXPECT_EQ(t.rules.at(44).label, "Sea and ocean");
  EXPECT_FALSE(t.rules.contains(48));  // the raster's nodata
  EXPECT_THAT(DefaultShelterTable("modis").status().message(), HasSubstr("worldcover or corine"));
}

TEST(ShelterTableTest, AFileOverridesAndAddsRules) {
  const std::string path = testing::FreshDir("shelter-table") + "/table.txt";
  std::ofstream(path) << "# my city\n"
                         "30 1.5            # lawns with trees\n"
                         "200, 4 landing    # a class of my own\n"
                         "\n";
  ShelterTable t = WorldCoverTable();
  ASSERT_TRUE(ApplyShelterFile(path, &t).ok());
  EXPECT_EQ(t.rules.at(30).shelter, 1.5);
  EXPECT_FALSE(t.rules.at(30).landing);
  EXPECT_EQ(t.rules.at(30).label, "lawns with trees");
  EXPECT_EQ(t.rules.at(200).shelter, 4.0);
  EXPECT_TRUE(t.rules.at(200).landing);
  EXPECT_EQ(t.rules.at(50).shelter, 5.0);
}

TEST(ShelterTableTest, BadFilesAreRefusedNamingTheLine) {
  const std::string dir = testing::FreshDir("shelter-table-bad");
  ShelterTable t = WorldCoverTable();
  std::ofstream(dir + "/a.txt") << "30 0\nforest 5\n";
  absl::Status s = ApplyShelterFile(dir + "/a.txt", &t);
  EXPECT_THAT(s.message(), HasSubstr("line 2: class 'forest' is not an integer"));
  std::ofstream(dir + "/b.txt") << "30 11\n";
  s = ApplyShelterFile(dir + "/b.txt", &t);
  EXPECT_THAT(s.message(), HasSubstr("line 1: class 30 needs a shelter factor in [0, 10]"));
  std::ofstream(dir + "/c.txt") << "30 1 land\n";
  s = ApplyShelterFile(dir + "/c.txt", &t);
  EXPECT_THAT(s.message(), HasSubstr("unknown word 'land'"));
  EXPECT_EQ(ApplyShelterFile(dir + "/none.txt", &t).code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace riskplan::geo
