// StagedDirectory: a directory whose files are written out of sight, then
// made to appear at its path in one rename, complete, or not at all.
//
//   absl::StatusOr<std::unique_ptr<StagedDirectory>> staged =
//       StagedDirectory::Create("maps/city", ExistingDirectory::kRefuse, "manifest.json");
//   if (!staged.ok()) return staged.status();
//   if (absl::Status s = (*staged)->WriteFile("a.bin", data, size); !s.ok()) return s;
//   return (*staged)->Commit();
//
// The files go into a temporary sibling of the final path, `.NAME.tmp-XXXXXX`
// in the same parent directory (so on the same file system, where a rename is
// atomic). Each file is flushed to disk (fsync) as it is written, the
// directory too before the rename, and the parent after it, so that after a
// crash or a power loss the final path holds either what it held before or
// every byte of the new directory. A StagedDirectory destroyed without a
// successful Commit() removes its temporary directory; a process that dies
// first leaves it behind, under a name starting with a dot (which
// LoadMapDirectory skips).
//
// Errors name the final path of the file at fault and the system's reason,
// e.g. "cannot write 'maps/city/density.f32': File too large".
//
// Not thread-safe. A process writing big files should ignore SIGXFSZ, so that
// a file size limit fails a write (EFBIG) instead of killing the process.
#ifndef RISKPLAN_CORE_MAP_STAGED_DIRECTORY_H_
#define RISKPLAN_CORE_MAP_STAGED_DIRECTORY_H_

#include <cstddef>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace riskplan {

// What happens when the final path already exists.
enum class ExistingDirectory {
  // It is left alone and the write fails with AlreadyExists.
  kRefuse,
  // It is replaced by the new directory in one step (the two are exchanged,
  // then the old one is removed), provided it is an empty directory or one
  // that holds the marker file given to Create(); anything else (a file, a
  // symbolic link, a directory of other things) is refused with
  // FailedPrecondition.
  kReplace,
};

class StagedDirectory {
 public:
  // Checks the final path `dir` against `existing` and `marker_file`, creates
  // its missing parent directories and the temporary directory.
  static absl::StatusOr<std::unique_ptr<StagedDirectory>> Create(const std::string& dir,
                                                                 ExistingDirectory existing,
                                                                 const std::string& marker_file);
  StagedDirectory(const StagedDirectory&) = delete;
  StagedDirectory& operator=(const StagedDirectory&) = delete;
  // Removes the temporary directory unless Commit() succeeded.
  ~StagedDirectory();

  // Writes the file `name` (no directory part) and flushes it to disk.
  // REQUIRES: Commit() has not been called.
  absl::Status WriteFile(const std::string& name, const void* data, size_t size);
  // Moves the directory to its final path (replacing what is there, as
  // `existing` allows). On failure the final path is as it was, and the
  // temporary directory is removed. REQUIRES: called at most once.
  absl::Status Commit();

  const std::string& final_path() const { return final_path_; }
  const std::string& temp_path() const { return temp_path_; }

 private:
  StagedDirectory() = default;

  std::string final_path_;
  std::string temp_path_;
  ExistingDirectory existing_ = ExistingDirectory::kRefuse;
  std::string marker_file_;
  bool committed_ = false;
};

// Writes `size` bytes to a new file `path` (failing if it exists), then
// flushes it to disk. On failure the partial file is removed; the error
// names `shown_path` (the path the caller's user knows the file by).
absl::Status WriteNewFileDurably(const std::string& path, const void* data, size_t size,
                                 const std::string& shown_path);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_MAP_STAGED_DIRECTORY_H_
