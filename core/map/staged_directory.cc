#include "core/map/staged_directory.h"

#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"

namespace riskplan {
namespace {

namespace fs = std::filesystem;

std::string Reason(int error) { return std::strerror(error); }

// fsync of a directory: its entries (a new file's name, a rename) reach the
// disk, not only the files' contents.
absl::Status SyncDirectory(const fs::path& dir, const std::string& shown) {
  const int fd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    return absl::UnavailableError(absl::StrCat("cannot open '", shown, "': ", Reason(errno)));
  }
  const int rc = fsync(fd);
  const int error = errno;
  close(fd);
  if (rc != 0) {
    return absl::UnavailableError(absl::StrCat("cannot flush '", shown, "': ", Reason(error)));
  }
  return absl::OkStatus();
}

// Whether `dir` may be replaced: an empty directory, or one holding `marker`.
absl::Status CheckReplaceable(const fs::path& dir, const std::string& marker) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(dir, ec);
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot examine '", dir.string(), "': ", ec.message()));
  }
  if (!fs::is_directory(status)) {
    return absl::FailedPreconditionError(
        absl::StrCat("'", dir.string(), "' exists and is not a directory; not replacing it"));
  }
  if (fs::is_empty(dir, ec) || fs::is_regular_file(dir / marker, ec)) return absl::OkStatus();
  return absl::FailedPreconditionError(
      absl::StrCat("'", dir.string(), "' is a directory without ", marker, "; not replacing it"));
}

// rename(2) that fails with EEXIST instead of replacing an empty directory;
// where the file system cannot do that (EINVAL), a check then a rename.
int RenameNoReplace(const fs::path& from, const fs::path& to) {
  if (renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0) return 0;
  if (errno != EINVAL) return -1;
  std::error_code ec;
  if (fs::exists(fs::symlink_status(to, ec))) {
    errno = EEXIST;
    return -1;
  }
  return rename(from.c_str(), to.c_str());
}

}  // namespace

absl::Status WriteNewFileDurably(const std::string& path, const void* data, size_t size,
                                 const std::string& shown_path) {
  const auto fail = [&](int error) {
    unlink(path.c_str());
    return absl::UnavailableError(absl::StrCat("cannot write '", shown_path, "': ", Reason(error)));
  };
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot create '", shown_path, "': ", Reason(errno)));
  }
  const char* bytes = static_cast<const char*>(data);
  size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, bytes + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : EIO;
      close(fd);
      return fail(error);
    }
    done += static_cast<size_t>(n);
  }
  // A full disk can surface only here (delayed allocation, NFS), so both
  // results count.
  if (fsync(fd) != 0) {
    const int error = errno;
    close(fd);
    return fail(error);
  }
  if (close(fd) != 0) return fail(errno);
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<StagedDirectory>> StagedDirectory::Create(
    const std::string& dir, ExistingDirectory existing, const std::string& marker_file) {
  fs::path final_path = fs::path(dir).lexically_normal();
  if (!final_path.has_filename()) final_path = final_path.parent_path();  // "a/b/"
  if (final_path.empty() || final_path.filename() == "." || final_path.filename() == "..") {
    return absl::InvalidArgumentError(absl::StrCat("'", dir, "' does not name a new directory"));
  }
  fs::path parent = final_path.parent_path();
  if (parent.empty()) parent = ".";
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot create directory '", parent.string(), "': ", ec.message()));
  }
  if (fs::exists(fs::symlink_status(final_path, ec))) {
    if (existing == ExistingDirectory::kRefuse) {
      return absl::AlreadyExistsError(absl::StrCat("'", final_path.string(), "' already exists"));
    }
    if (absl::Status s = CheckReplaceable(final_path, marker_file); !s.ok()) return s;
  }
  std::string temp =
      (parent / absl::StrCat(".", final_path.filename().string(), ".tmp-XXXXXX")).string();
  if (mkdtemp(temp.data()) == nullptr) {
    return absl::UnavailableError(
        absl::StrCat("cannot create a directory in '", parent.string(), "': ", Reason(errno)));
  }
  std::unique_ptr<StagedDirectory> staged(new StagedDirectory);
  staged->final_path_ = final_path.string();
  staged->temp_path_ = temp;
  staged->existing_ = existing;
  staged->marker_file_ = marker_file;
  return staged;
}

StagedDirectory::~StagedDirectory() {
  if (committed_) return;
  std::error_code ignored;
  fs::remove_all(temp_path_, ignored);
}

absl::Status StagedDirectory::WriteFile(const std::string& name, const void* data, size_t size) {
  return WriteNewFileDurably((fs::path(temp_path_) / name).string(), data, size,
                             (fs::path(final_path_) / name).string());
}

absl::Status StagedDirectory::Commit() {
  const fs::path final_path = final_path_;
  const fs::path temp_path = temp_path_;
  const fs::path parent = final_path.has_parent_path() ? final_path.parent_path() : ".";
  if (absl::Status s = SyncDirectory(temp_path, temp_path_); !s.ok()) return s;
  std::error_code ec;
  const bool replace =
      existing_ == ExistingDirectory::kReplace && fs::exists(fs::symlink_status(final_path, ec));
  if (!replace) {
    if (RenameNoReplace(temp_path, final_path) != 0) {
      if (errno == EEXIST || errno == ENOTEMPTY) {
        return absl::AlreadyExistsError(absl::StrCat("'", final_path_, "' already exists"));
      }
      return absl::UnavailableError(
          absl::StrCat("cannot rename '", temp_path_, "' to '", final_path_, "': ", Reason(errno)));
    }
    committed_ = true;
    return SyncDirectory(parent, parent.string());
  }
  if (absl::Status s = CheckReplaceable(final_path, marker_file_); !s.ok()) return s;
  // One step: a reader finds the old directory or the new one, never none.
  if (renameat2(AT_FDCWD, temp_path.c_str(), AT_FDCWD, final_path.c_str(), RENAME_EXCHANGE) == 0) {
    committed_ = true;
    fs::remove_all(temp_path, ec);  // the old directory, now here
    return SyncDirectory(parent, parent.string());
  }
  if (errno != EINVAL) {
    return absl::UnavailableError(absl::StrCat("cannot exchange '", temp_path_, "' and '",
                                               final_path_, "': ", Reason(errno)));
  }
  // A file system without RENAME_EXCHANGE: the old directory is moved aside
  // first, so a reader may briefly find nothing at the path, but never a
  // partial directory.
  std::string aside =
      (parent / absl::StrCat(".", final_path.filename().string(), ".old-XXXXXX")).string();
  if (mkdtemp(aside.data()) == nullptr || rename(final_path.c_str(), aside.c_str()) != 0) {
    const int error = errno;
    fs::remove(aside, ec);
    return absl::UnavailableError(
        absl::StrCat("cannot move '", final_path_, "' aside: ", Reason(error)));
  }
  if (rename(temp_path.c_str(), final_path.c_str()) != 0) {
    const int error = errno;
    rename(aside.c_str(), final_path.c_str());  // the old one back
    return absl::UnavailableError(
        absl::StrCat("cannot rename '", temp_path_, "' to '", final_path_, "': ", Reason(error)));
  }
  committed_ = true;
  fs::remove_all(aside, ec);
  return SyncDirectory(parent, parent.string());
}

}  // namespace riskplan
