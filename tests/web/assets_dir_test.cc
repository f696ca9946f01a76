// Where riskplan-web finds its page without --assets_dir (web/gateway.h,
// FindAssetsDir): the first candidate directory holding index.html, so an
// installed riskplan-web whose source tree is gone serves the installed copy.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "web/gateway.h"

namespace riskplan::web {
namespace {

class FindAssetsDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = std::filesystem::path(::testing::TempDir()) /
            ("riskplan-assets-" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }

  // A directory, with an index.html when `page`.
  std::string Dir(const std::string& name, bool page) {
    const std::filesystem::path dir = root_ / name;
    std::filesystem::create_directories(dir);
    if (page) std::ofstream(dir / "index.html") << "<!DOCTYPE html>\n";
    return dir.string();
  }

  std::filesystem::path root_;
};

TEST_F(FindAssetsDirTest, TheSourceTreeFirstWhenItIsThere) {
  const std::string source = Dir("source/web/static", true);
  const std::string installed = Dir("prefix/share/riskplan/web", true);
  absl::StatusOr<std::string> found = FindAssetsDir({source, installed});
  ASSERT_TRUE(found.ok()) << found.status();
  EXPECT_EQ(*found, source);
}

TEST_F(FindAssetsDirTest, TheInstalledCopyWhenTheSourceTreeIsGone) {
  const std::string source = (root_ / "source/web/static").string();  // never made
  const std::string empty = Dir("moved/share/riskplan/web", false);   // no index.html
  const std::string installed = Dir("prefix/share/riskplan/web", true);
  absl::StatusOr<std::string> found = FindAssetsDir({source, empty, installed});
  ASSERT_TRUE(found.ok()) << found.status();
  EXPECT_EQ(*found, installed);
}

TEST_F(FindAssetsDirTest, NoneNamesEveryCandidate) {
  const std::string a = (root_ / "a").string(), b = Dir("b", false);
  absl::StatusOr<std::string> found = FindAssetsDir({a, b});
  ASSERT_FALSE(found.ok());
  EXPECT_EQ(found.status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(found.status().message(), "the page's files (index.html) are in none of " + a + ", " +
                                          b + "; give their directory with --assets_dir");
}

}  // namespace
}  // namespace riskplan::web
