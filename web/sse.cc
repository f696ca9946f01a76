#include "web/sse.h"

#include <cassert>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace riskplan::web {

std::string FormatSseEvent(uint64_t id, absl::string_view type, absl::string_view data) {
  assert(!type.empty() && type.find_first_of("\r\n") == absl::string_view::npos);
  std::string out = absl::StrCat("id: ", id, "\nevent: ", type, "\n");
  // A bare "\r" also ends a line for the browser's parser, so every kind of
  // line break starts a new data field; otherwise a "\r" in the data would cut
  // the event short.
  size_t start = 0;
  while (true) {
    const size_t end = data.find_first_of("\r\n", start);
    absl::StrAppend(
        &out, "data: ",
        data.substr(start, end == absl::string_view::npos ? absl::string_view::npos : end - start),
        "\n");
    if (end == absl::string_view::npos) break;
    start = end + 1;
    if (data[end] == '\r' && start < data.size() && data[start] == '\n') ++start;
  }
  out += "\n";
  return out;
}

std::string FormatSseComment(absl::string_view text) {
  assert(text.find_first_of("\r\n") == absl::string_view::npos);
  return absl::StrCat(": ", text, "\n\n");
}

std::string FormatSseRetry(int retry_ms) { return absl::StrCat("retry: ", retry_ms, "\n\n"); }

std::optional<uint64_t> ParseLastEventId(absl::string_view value) {
  value = absl::StripAsciiWhitespace(value);
  if (value.empty()) return 0;
  if (value.size() > 19) return std::nullopt;
  for (char c : value) {
    if (!absl::ascii_isdigit(static_cast<unsigned char>(c))) return std::nullopt;
  }
  uint64_t id = 0;
  if (!absl::SimpleAtoi(value, &id)) return std::nullopt;
  return id;
}

}  // namespace riskplan::web
