// WriteMapBundleAtomically: a bundle appears complete or not at all, an
// existing one is replaced in one step or left alone, and a write that fails
// (a file size limit, a path that cannot be a directory) names the file and
// leaves nothing behind. Tests run as root, so permissions cannot make a
// write fail: a file size limit (EFBIG) and a regular file where a directory
// must be (ENOTDIR) do, whoever runs them.
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/map/map_bundle.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/map/test_dir_cleanup.h"

namespace riskplan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// A fresh, empty directory per test: the parent of the bundles it writes.
fs::path TestDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(::testing::TempDir()) /
                       ::riskplan::testing::ProcessRoot("riskplan_map_bundle_atomic_test") /
                       info->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// 20 x 10 cells: each float layer is 800 bytes.
std::shared_ptr<const RiskMap> TinyMap(const std::string& name, float density) {
  MapHeader header;
  header.name = name;
  header.res = 5.0;
  header.nx = 20;
  header.ny = 10;
  MapLayers layers;
  layers.density.assign(200, density);
  layers.shelter.assign(200, 2.0f);
  layers.terrain.assign(200, 100.0f);
  layers.nofly.assign(200, 0);
  auto map = RiskMap::Create(header, layers, 10.0, 10.0);
  EXPECT_TRUE(map.ok()) << map.status();
  return *map;
}

// Every name in `dir`, hidden ones included.
std::set<std::string> Entries(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename());
  return names;
}

// WriteMapBundleAtomically in a child process limited to files of
// `max_file_bytes` (RLIMIT_FSIZE, SIGXFSZ ignored so that a write fails with
// EFBIG): the status message, or "OK".
std::string WriteUnderFileSizeLimit(const RiskMap& map, const fs::path& dir,
                                    ExistingDirectory existing, rlim_t max_file_bytes) {
  int out[2];
  if (pipe(out) != 0) return "pipe failed";
  const pid_t pid = fork();
  if (pid == 0) {
    close(out[0]);
    signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{max_file_bytes, max_file_bytes};
    if (setrlimit(RLIMIT_FSIZE, &limit) != 0) _exit(2);
    const absl::Status s = WriteMapBundleAtomically(map, dir.string(), existing);
    const std::string message = s.ok() ? "OK" : std::string(s.message());
    if (write(out[1], message.data(), message.size()) < 0) _exit(3);
    _exit(0);
  }
  close(out[1]);
  std::string message;
  char buffer[512];
  ssize_t n = 0;
  while ((n = read(out[0], buffer, sizeof(buffer))) > 0) message.append(buffer, n);
  close(out[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;
  return message;
}

// Every test's folder is under TempDir()/riskplan_map_bundle_atomic_test, removed when
// the program ends.
const ::testing::Environment* const kCleanup =
    ::riskplan::testing::RemoveAtExit("riskplan_map_bundle_atomic_test");

TEST(MapBundleAtomicTest, ARunLeavesNoFolderBehind) {
  EXPECT_THAT(
      ::riskplan::testing::LeftBehind("MapBundleAtomicTest.WritesACompleteBundleAndNothingElse"),
      ::testing::IsEmpty());
}

TEST(MapBundleAtomicTest, WritesACompleteBundleAndNothingElse) {
  const fs::path parent = TestDir();
  const fs::path dir = parent / "maps" / "city";  // "maps" is created
  ASSERT_TRUE(WriteMapBundleAtomically(*TinyMap("city", 0.01f), dir.string()).ok());
  auto loaded = LoadMapBundle(dir.string());
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ((*loaded)->name(), "city");
  EXPECT_EQ(Entries(parent / "maps"), std::set<std::string>{"city"});
  EXPECT_EQ(Entries(dir), (std::set<std::string>{"density.f32", "manifest.json", "nofly.u8",
                                                 "shelter.f32", "terrain.f32"}));
}

TEST(MapBundleAtomicTest, LeavesAnExistingBundleAloneUnlessToldToReplaceIt) {
  const fs::path parent = TestDir();
  const fs::path dir = parent / "city";
  ASSERT_TRUE(WriteMapBundleAtomically(*TinyMap("old", 0.01f), dir.string()).ok());

  const absl::Status refused = WriteMapBundleAtomically(*TinyMap("new", 0.02f), dir.string());
  EXPECT_EQ(refused.code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(refused.message(), HasSubstr(dir.string()));
  EXPECT_EQ((*LoadMapBundle(dir.string()))->name(), "old");

  ASSERT_TRUE(
      WriteMapBundleAtomically(*TinyMap("new", 0.02f), dir.string(), ExistingDirectory::kReplace)
          .ok());
  EXPECT_EQ((*LoadMapBundle(dir.string()))->name(), "new");
  EXPECT_EQ(Entries(parent), std::set<std::string>{"city"});  // the old one is gone too
}

TEST(MapBundleAtomicTest, ReplacesOnlyABundleOrAnEmptyDirectory) {
  const fs::path parent = TestDir();
  fs::create_directories(parent / "empty");
  EXPECT_TRUE(WriteMapBundleAtomically(*TinyMap("city", 0.01f), (parent / "empty").string(),
                                       ExistingDirectory::kReplace)
                  .ok());
  EXPECT_TRUE(LoadMapBundle((parent / "empty").string()).ok());

  fs::create_directories(parent / "other");
  std::ofstream(parent / "other" / "README") << "not a map";
  std::ofstream(parent / "file") << "not a directory";
  for (const char* name : {"other", "file"}) {
    const absl::Status s = WriteMapBundleAtomically(
        *TinyMap("city", 0.01f), (parent / name).string(), ExistingDirectory::kReplace);
    EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << name;
    EXPECT_THAT(s.message(), HasSubstr((parent / name).string()));
  }
  EXPECT_TRUE(fs::is_regular_file(parent / "other" / "README"));
  EXPECT_TRUE(fs::is_regular_file(parent / "file"));
  EXPECT_EQ(Entries(parent), (std::set<std::string>{"empty", "file", "other"}));
}

// A full disk, as far as one process can tell: writes fail part way.
TEST(MapBundleAtomicTest, AFileSizeLimitFailsCleanlyNamingTheFile) {
  const fs::path parent = TestDir();
  const fs::path dir = parent / "city";
  // 500 bytes: the first layer (800 bytes) cannot be written.
  const std::string message =
      WriteUnderFileSizeLimit(*TinyMap("city", 0.01f), dir, ExistingDirectory::kRefuse, 500);
  EXPECT_THAT(message, HasSubstr((dir / "density.f32").string()));
  EXPECT_THAT(message, HasSubstr("File too large"));
  EXPECT_TRUE(Entries(parent).empty()) << "no bundle and no temporary directory";
}

TEST(MapBundleAtomicTest, AFailedReplacementLeavesTheOldBundle) {
  const fs::path parent = TestDir();
  const fs::path dir = parent / "city";
  ASSERT_TRUE(WriteMapBundleAtomically(*TinyMap("old", 0.01f), dir.string()).ok());
  const std::string message =
      WriteUnderFileSizeLimit(*TinyMap("new", 0.02f), dir, ExistingDirectory::kReplace, 500);
  EXPECT_THAT(message, HasSubstr((dir / "density.f32").string()));
  auto loaded = LoadMapBundle(dir.string());
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ((*loaded)->name(), "old");
  EXPECT_EQ(Entries(parent), std::set<std::string>{"city"});
}

TEST(MapBundleAtomicTest, APathThroughARegularFileFailsCleanly) {
  const fs::path parent = TestDir();
  std::ofstream(parent / "file") << "not a directory";
  const absl::Status s =
      WriteMapBundleAtomically(*TinyMap("city", 0.01f), (parent / "file" / "city").string());
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(s.message(), HasSubstr((parent / "file").string()));
  EXPECT_THAT(s.message(), HasSubstr("Not a directory"));
  EXPECT_EQ(Entries(parent), std::set<std::string>{"file"});
}

// A writer killed before its rename leaves its temporary directory, possibly
// with a complete manifest: a maps directory still loads, without it.
TEST(MapBundleAtomicTest, LoadMapDirectorySkipsAnInterruptedWrite) {
  const fs::path maps = TestDir();
  ASSERT_TRUE(WriteMapBundleAtomically(*TinyMap("city", 0.01f), (maps / "city").string()).ok());
  fs::copy(maps / "city", maps / ".city.tmp-Ab12Cd");
  auto loaded = LoadMapDirectory(maps.string());
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ASSERT_EQ(loaded->size(), 1u);
  EXPECT_EQ((*loaded)[0]->name(), "city");
}

// Private manifest fields (an importer's provenance) are written after the
// format's own and ignored by the loader; bad ones are refused before
// anything is written.
TEST(MapBundleAtomicTest, PrivateFieldsGoIntoTheManifestAndBadOnesWriteNothing) {
  const fs::path parent = TestDir();
  const fs::path dir = parent / "city";
  ASSERT_TRUE(WriteMapBundleAtomically(*TinyMap("city", 0.01f), dir.string(),
                                       ExistingDirectory::kRefuse,
                                       {{"x_import", R"({"command": "import", "inputs": [1, 2]})"}})
                  .ok());
  std::ifstream in(dir / "manifest.json");
  const std::string manifest((std::istreambuf_iterator<char>(in)), {});
  EXPECT_THAT(manifest, HasSubstr("\"x_import\": {"));
  EXPECT_THAT(manifest, HasSubstr("\"command\": \"import\""));
  EXPECT_LT(manifest.find("\"layers\""), manifest.find("\"x_import\""));
  auto loaded = LoadMapBundle(dir.string());
  ASSERT_TRUE(loaded.ok()) << loaded.status();

  const std::vector<std::pair<std::vector<std::pair<std::string, std::string>>, std::string>>
      refused = {{{{"import", "{}"}}, "'import' must start with \"x_\""},
                 {{{"x_a", "{not json"}}, "'x_a' is not JSON"},
                 {{{"x_a", "1"}, {"x_a", "2"}}, "'x_a' is given twice"}};
  for (const auto& [fields, message] : refused) {
    const absl::Status s = WriteMapBundleAtomically(
        *TinyMap("other", 0.01f), (parent / "other").string(), ExistingDirectory::kRefuse, fields);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
    EXPECT_THAT(s.message(), HasSubstr(message));
    EXPECT_EQ(Entries(parent), std::set<std::string>{"city"});
  }
}

}  // namespace
}  // namespace riskplan
