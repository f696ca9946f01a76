#include "geo/grid_regions.h"

#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace riskplan::geo {
namespace {

// A grid from text rows, north row first as written; '#' is 1.
std::vector<uint8_t> Mask(const std::vector<std::string>& rows, int* nx, int* ny) {
  *ny = static_cast<int>(rows.size());
  *nx = static_cast<int>(rows[0].size());
  std::vector<uint8_t> mask(static_cast<size_t>(*nx) * *ny);
  for (int r = 0; r < *ny; ++r) {
    for (int i = 0; i < *nx; ++i)
      mask[static_cast<size_t>(*ny - 1 - r) * *nx + i] = rows[r][i] == '#';
  }
  return mask;
}

TEST(GridRegionsTest, ComponentsAreFourConnected) {
  int nx = 0, ny = 0;
  const auto mask = Mask({"##..#", "##.#.", "....."}, &nx, &ny);
  int32_t count = 0;
  const auto labels = LabelComponents(mask, nx, ny, &count);
  // The two single cells touch only at a corner: two components.
  EXPECT_EQ(count, 3);
  EXPECT_EQ(labels[1 * nx + 0], labels[2 * nx + 1]);
  EXPECT_NE(labels[1 * nx + 3], labels[2 * nx + 4]);
  EXPECT_EQ(labels[0], 0);
}

TEST(GridRegionsTest, DeepestCellIsTheCentreOfAField) {
  int nx = 0, ny = 0;
  const auto mask = Mask({"..........", ".#######..", ".#######..", ".#######..", ".#######..",
                          ".#######..", ".........."},
                         &nx, &ny);
  int32_t count = 0;
  const auto labels = LabelComponents(mask, nx, ny, &count);
  ASSERT_EQ(count, 1);
  const auto regions = Regions(labels, count, nx, ny, {});
  ASSERT_EQ(regions.size(), 1u);
  EXPECT_EQ(regions[0].cells, 35);
  EXPECT_EQ(regions[0].deepest_i, 4);  // columns 1..7
  EXPECT_EQ(regions[0].deepest_j, 3);  // rows 1..5
  EXPECT_FLOAT_EQ(regions[0].depth, 3.0f);
}

TEST(GridRegionsTest, TheMapEdgeBoundsAFieldAndExcludedCellsAreNeverChosen) {
  int nx = 0, ny = 0;
  const auto mask = Mask({"#####", "#####", "#####"}, &nx, &ny);
  int32_t count = 0;
  const auto labels = LabelComponents(mask, nx, ny, &count);
  auto regions = Regions(labels, count, nx, ny, {});
  ASSERT_EQ(regions.size(), 1u);
  EXPECT_EQ(regions[0].deepest_i, 2);
  EXPECT_EQ(regions[0].deepest_j, 1);
  std::vector<uint8_t> excluded(mask.size(), 0);
  excluded[1 * nx + 2] = 1;
  regions = Regions(labels, count, nx, ny, excluded);
  ASSERT_EQ(regions.size(), 1u);
  EXPECT_FALSE(regions[0].deepest_i == 2 && regions[0].deepest_j == 1);
  excluded.assign(mask.size(), 1);
  EXPECT_TRUE(Regions(labels, count, nx, ny, excluded).empty());
}

}  // namespace
}  // namespace riskplan::geo
