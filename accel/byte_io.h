// Little-endian byte writers and readers for the shim protocol's payloads
// and blobs. The reader never reads past its input: every Read* returns
// false instead, and a caller turns that into DataLoss.
#ifndef RISKPLAN_ACCEL_BYTE_IO_H_
#define RISKPLAN_ACCEL_BYTE_IO_H_

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>

#include "absl/strings/string_view.h"

namespace riskplan::accel {

class ByteWriter {
 public:
  explicit ByteWriter(std::string* out) : out_(out) {}

  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));  // little-endian hosts only (see docs)
    out_->append(bytes, sizeof(T));
  }
  void PutBytes(const void* data, size_t size) {
    out_->append(static_cast<const char*>(data), size);
  }
  // u32 length, then the bytes.
  void PutString(absl::string_view s) {
    Put<uint32_t>(static_cast<uint32_t>(s.size()));
    out_->append(s.data(), s.size());
  }

 private:
  std::string* out_;
};

class ByteReader {
 public:
  explicit ByteReader(absl::string_view in) : in_(in) {}

  template <typename T>
  bool Get(T* value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (in_.size() - pos_ < sizeof(T)) return false;
    std::memcpy(value, in_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  bool GetBytes(void* data, size_t size) {
    if (in_.size() - pos_ < size) return false;
    std::memcpy(data, in_.data() + pos_, size);
    pos_ += size;
    return true;
  }
  // A view of the next `size` bytes.
  bool View(size_t size, absl::string_view* view) {
    if (in_.size() - pos_ < size) return false;
    *view = in_.substr(pos_, size);
    pos_ += size;
    return true;
  }
  bool GetString(std::string* s, size_t max_size = 4096) {
    uint32_t size = 0;
    absl::string_view view;
    if (!Get(&size) || size > max_size || !View(size, &view)) return false;
    s->assign(view.data(), view.size());
    return true;
  }
  size_t remaining() const { return in_.size() - pos_; }
  bool done() const { return pos_ == in_.size(); }

 private:
  absl::string_view in_;
  size_t pos_ = 0;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_BYTE_IO_H_
