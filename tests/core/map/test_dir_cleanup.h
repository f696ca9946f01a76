// The map bundle tests' folders: each test writes under
// ::testing::TempDir()/ProcessRoot(ROOT), a folder of this process alone
// (ctest runs the tests of one program as parallel processes: a shared folder
// removed by one of them would vanish under another), and the whole of it is
// removed when the test program ends (a gtest environment's TearDown), so that a run leaves nothing
// behind. LeftBehind() runs one test of this program again, as a child with
// its own TEST_TMPDIR, and lists what the child left there.
#ifndef RISKPLAN_TESTS_CORE_MAP_TEST_DIR_CLEANUP_H_
#define RISKPLAN_TESTS_CORE_MAP_TEST_DIR_CLEANUP_H_

#include <stdlib.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace riskplan::testing {

// ROOT-PID: this process's own root.
inline std::string ProcessRoot(const std::string& root) {
  return root + "-" + std::to_string(getpid());
}

class RemoveTestRoot : public ::testing::Environment {
 public:
  explicit RemoveTestRoot(std::string root) : root_(std::move(root)) {}
  void TearDown() override {
    std::error_code ignored;
    std::filesystem::remove_all(std::filesystem::path(::testing::TempDir()) / ProcessRoot(root_),
                                ignored);
  }

 private:
  const std::string root_;
};

// Registers the removal of TempDir()/root at the end of the program; use as
// `static const auto* kCleanup = RemoveAtExit("...")` at namespace scope.
inline ::testing::Environment* RemoveAtExit(const std::string& root) {
  return ::testing::AddGlobalTestEnvironment(new RemoveTestRoot(root));
}

// What running `test` (a gtest filter) of this very program leaves in a
// fresh TEST_TMPDIR: the names of its entries; "child failed" if it failed.
inline std::vector<std::string> LeftBehind(const std::string& test) {
  char dir_template[] = "/tmp/riskplan-leftover-XXXXXX";
  if (mkdtemp(dir_template) == nullptr) return {"mkdtemp failed"};
  const std::string dir = dir_template;
  const std::string command = "TEST_TMPDIR=" + dir + " /proc/" + std::to_string(getpid()) +
                              "/exe --gtest_filter=" + test + " >/dev/null 2>&1";
  std::vector<std::string> left;
  if (std::system(command.c_str()) != 0) left.push_back("child failed");
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    left.push_back(entry.path().filename().string());
  }
  std::filesystem::remove_all(dir);
  return left;
}

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_CORE_MAP_TEST_DIR_CLEANUP_H_
