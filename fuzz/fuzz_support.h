// What the fuzz targets share: reading a structured input and a scratch
// directory for the targets whose code under test reads files.
#ifndef RISKPLAN_FUZZ_FUZZ_SUPPORT_H_
#define RISKPLAN_FUZZ_FUZZ_SUPPORT_H_

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>

namespace riskplan::fuzz {

// A property the code under test broke: says which, and aborts (libFuzzer
// saves the input as a crash).
[[noreturn]] inline void Fail(std::string_view what) {
  std::fprintf(stderr, "fuzz property broken: %.*s\n", static_cast<int>(what.size()), what.data());
  std::fflush(stderr);
  abort();
}

// Reads little-endian integers and byte strings off the front of a fuzz
// input. Past the end every read gives zeros (or an empty string), so any
// input is a valid one: a target never refuses an input for being short.
class InputReader {
 public:
  InputReader(const uint8_t* data, size_t size)
      : in_(reinterpret_cast<const char*>(data), size) {}
  explicit InputReader(std::string_view in) : in_(in) {}

  template <typename T>
  T Get() {
    T value{};
    const size_t n = std::min(sizeof(T), in_.size() - pos_);
    std::memcpy(&value, in_.data() + pos_, n);
    pos_ += n;
    return value;
  }
  // The next `size` bytes, or as many as are left.
  std::string_view Bytes(size_t size) {
    size = std::min(size, in_.size() - pos_);
    std::string_view out = in_.substr(pos_, size);
    pos_ += size;
    return out;
  }
  // A u16 length, then that many bytes.
  std::string_view Sized() { return Bytes(Get<uint16_t>()); }
  std::string_view Rest() { return Bytes(in_.size() - pos_); }
  bool done() const { return pos_ == in_.size(); }

 private:
  std::string_view in_;
  size_t pos_ = 0;
};

// A private directory for one fuzzing process, in /dev/shm when there is one
// (files there cost no disk I/O), removed with its contents at exit.
class ScratchDir {
 public:
  ScratchDir() {
    std::error_code ec;
    const char* base = std::filesystem::is_directory("/dev/shm", ec) && access("/dev/shm", W_OK) == 0
                           ? "/dev/shm"
                           : (getenv("TMPDIR") != nullptr ? getenv("TMPDIR") : "/tmp");
    std::string pattern = std::string(base) + "/riskplan-fuzz-XXXXXX";
    if (mkdtemp(pattern.data()) == nullptr) abort();
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }

  // Empties the directory (every input starts from nothing).
  void Clear() const {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(path_, ec)) {
      std::error_code ignored;
      std::filesystem::remove_all(entry.path(), ignored);
    }
  }

 private:
  std::filesystem::path path_;
};

}  // namespace riskplan::fuzz

#endif  // RISKPLAN_FUZZ_FUZZ_SUPPORT_H_
