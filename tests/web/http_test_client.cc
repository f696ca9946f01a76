#include "tests/web/http_test_client.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"

namespace riskplan::testing {
namespace {

absl::StatusOr<int> Connect(const std::string& address) {
  const size_t colon = address.rfind(':');
  int port = 0;
  if (colon == std::string::npos || !absl::SimpleAtoi(address.substr(colon + 1), &port)) {
    return absl::InvalidArgumentError("address needs a port: " + address);
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  if (inet_pton(AF_INET, address.substr(0, colon).c_str(), &addr.sin_addr) != 1) {
    return absl::InvalidArgumentError("address needs an IPv4 host: " + address);
  }
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return absl::InternalError("socket failed");
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    close(fd);
    return absl::UnavailableError("cannot connect to " + address);
  }
  return fd;
}

int PollMs(absl::Time deadline) {
  return static_cast<int>(
      std::clamp<int64_t>(absl::ToInt64Milliseconds(deadline - absl::Now()), 0, 1 << 30));
}

// Reads what arrives before `deadline`: bytes read, 0 when none, -1 at EOF.
ssize_t ReadSome(int fd, std::string* out, absl::Time deadline) {
  pollfd p{fd, POLLIN, 0};
  if (poll(&p, 1, PollMs(deadline)) <= 0) return 0;
  char buffer[16384];
  const ssize_t n = read(fd, buffer, sizeof(buffer));
  if (n <= 0) return -1;
  out->append(buffer, static_cast<size_t>(n));
  return n;
}

}  // namespace

absl::StatusOr<std::unique_ptr<SseStream>> SseStream::Open(
    const std::string& address, const std::string& path,
    const std::map<std::string, std::string>& headers, absl::Duration timeout) {
  return Start(address, "GET", path, "", headers, timeout);
}

absl::StatusOr<std::unique_ptr<SseStream>> SseStream::Start(
    const std::string& address, const std::string& method, const std::string& path,
    const std::string& body, const std::map<std::string, std::string>& headers,
    absl::Duration timeout) {
  absl::StatusOr<int> fd = Connect(address);
  if (!fd.ok()) return fd.status();
  std::unique_ptr<SseStream> stream(new SseStream);
  stream->fd_ = *fd;
  std::string request =
      absl::StrCat(method, " ", path, " HTTP/1.1\r\nHost: ", address, "\r\nConnection: close\r\n");
  for (const auto& [name, value] : headers) absl::StrAppend(&request, name, ": ", value, "\r\n");
  if (!body.empty() || method == "POST") {
    absl::StrAppend(&request, "Content-Type: application/json\r\nContent-Length: ", body.size(),
                    "\r\n");
  }
  absl::StrAppend(&request, "\r\n", body);
  if (send(stream->fd_, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    return absl::UnavailableError("cannot send the request");
  }
  const absl::Time deadline = absl::Now() + timeout;
  std::string head;
  size_t end;
  while ((end = head.find("\r\n\r\n")) == std::string::npos) {
    const ssize_t n = ReadSome(stream->fd_, &head, deadline);
    if (n < 0) return absl::DataLossError("the connection closed before the headers: " + head);
    if (n == 0 && absl::Now() >= deadline) {
      return absl::DeadlineExceededError("no HTTP headers from " + address);
    }
  }
  stream->raw_ = head.substr(end + 4);
  std::vector<std::string> lines = absl::StrSplit(head.substr(0, end), "\r\n");
  std::vector<std::string> status = absl::StrSplit(lines[0], absl::MaxSplits(' ', 2));
  if (status.size() < 2 || !absl::SimpleAtoi(status[1], &stream->response_.status)) {
    return absl::DataLossError("bad status line: " + lines[0]);
  }
  for (size_t i = 1; i < lines.size(); ++i) {
    const size_t colon = lines[i].find(':');
    if (colon == std::string::npos) continue;
    stream->response_.headers[absl::AsciiStrToLower(lines[i].substr(0, colon))] =
        std::string(absl::StripAsciiWhitespace(lines[i].substr(colon + 1)));
  }
  auto te = stream->response_.headers.find("transfer-encoding");
  stream->chunked_ = te != stream->response_.headers.end() && te->second == "chunked";
  auto cl = stream->response_.headers.find("content-length");
  size_t length = 0;
  if (!stream->chunked_ && cl != stream->response_.headers.end() &&
      absl::SimpleAtoi(cl->second, &length)) {
    stream->content_length_ = length;
  }
  stream->Decode();
  return stream;
}

SseStream::~SseStream() { Close(); }

void SseStream::Close() {
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
}

void SseStream::Decode() {
  if (!chunked_) {
    text_ += raw_;
    all_ += raw_;
    raw_.clear();
    if (content_length_ >= 0 && all_.size() >= static_cast<size_t>(content_length_)) ended_ = true;
  } else {
    while (!ended_) {
      const size_t line_end = raw_.find("\r\n");
      if (line_end == std::string::npos) break;
      size_t size = 0;
      if (!absl::SimpleHexAtoi(raw_.substr(0, line_end), &size)) {
        ended_ = true;  // not chunked framing: a test failure shows in the events
        break;
      }
      if (raw_.size() < line_end + 2 + size + 2) break;
      const std::string chunk = raw_.substr(line_end + 2, size);
      raw_.erase(0, line_end + 2 + size + 2);
      if (size == 0) {
        ended_ = true;
        break;
      }
      text_ += chunk;
      all_ += chunk;
    }
  }
  Parse();
}

bool SseStream::ReadMore(absl::Time deadline) {
  if (ended_ || fd_ < 0) return false;
  const ssize_t n = ReadSome(fd_, &raw_, deadline);
  if (n < 0) {
    if (!chunked_) ended_ = true;
    Decode();
    ended_ = true;
    return false;
  }
  Decode();
  return !ended_;
}

// The parsing rules of the HTML standard's event-stream interpretation, for
// the "\n" line ends the gateway writes.
void SseStream::Parse() {
  size_t line_end;
  while ((line_end = text_.find('\n')) != std::string::npos) {
    std::string line = text_.substr(0, line_end);
    text_.erase(0, line_end + 1);
    if (line.empty()) {
      if (pending_has_data_) {
        if (!pending_.data.empty() && pending_.data.back() == '\n') pending_.data.pop_back();
        if (pending_.type.empty()) pending_.type = "message";
        events_.push_back(pending_);
      }
      pending_.type.clear();
      pending_.data.clear();
      pending_has_data_ = false;
      continue;
    }
    if (line[0] == ':') continue;
    const size_t colon = line.find(':');
    std::string field = line.substr(0, colon);
    std::string value = colon == std::string::npos ? "" : line.substr(colon + 1);
    if (!value.empty() && value[0] == ' ') value.erase(0, 1);
    if (field == "id") {
      pending_.id = value;
    } else if (field == "event") {
      pending_.type = value;
    } else if (field == "data") {
      pending_.data += value + "\n";
      pending_has_data_ = true;
    } else if (field == "retry") {
      absl::SimpleAtoi(value, &retry_ms_);
    }
  }
}

bool SseStream::ReadEvents(size_t count, absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (events_.size() < count) {
    if (ended_ || absl::Now() >= deadline) return events_.size() >= count;
    ReadMore(deadline);
  }
  return true;
}

bool SseStream::ReadAll(absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (!ended_) {
    if (absl::Now() >= deadline) return false;
    ReadMore(deadline);
  }
  response_.body = all_;
  return true;
}

absl::StatusOr<HttpResponse> HttpRequest(const std::string& address, const std::string& method,
                                         const std::string& path, const std::string& body,
                                         const std::map<std::string, std::string>& headers,
                                         absl::Duration timeout) {
  auto stream = SseStream::Start(address, method, path, body, headers, timeout);
  if (!stream.ok()) return stream.status();
  if (!(*stream)->ReadAll(timeout)) {
    return absl::DeadlineExceededError(absl::StrCat(method, " ", path, ": no complete answer"));
  }
  return (*stream)->response();
}

}  // namespace riskplan::testing
