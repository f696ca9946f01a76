// A small HTTP/1.1 client for the gateway's tests, on plain sockets (so the
// tests see the bytes on the wire, chunked framing and all): one request per
// connection, and event streams read incrementally, parsed as a browser's
// EventSource would parse them. Every read has a deadline.
#ifndef RISKPLAN_TESTS_WEB_HTTP_TEST_CLIENT_H_
#define RISKPLAN_TESTS_WEB_HTTP_TEST_CLIENT_H_

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace riskplan::testing {

struct HttpResponse {
  int status = 0;
  std::map<std::string, std::string> headers;  // names lower-cased
  std::string body;                             // de-chunked
};

// One request on a new connection ("Connection: close"), read to its end.
absl::StatusOr<HttpResponse> HttpRequest(const std::string& address, const std::string& method,
                                         const std::string& path, const std::string& body = "",
                                         const std::map<std::string, std::string>& headers = {},
                                         absl::Duration timeout = absl::Seconds(60));

struct SseEvent {
  std::string id;
  std::string type;  // "message" when the event names none
  std::string data;
};

// An open event stream.
class SseStream {
 public:
  // Connects and sends GET `path` with `headers`; reads the status line and
  // the headers. The body (if any, when the status is not 200) is in
  // response().body once ReadAll() has run.
  static absl::StatusOr<std::unique_ptr<SseStream>> Open(
      const std::string& address, const std::string& path,
      const std::map<std::string, std::string>& headers = {},
      absl::Duration timeout = absl::Seconds(60));
  // Any request, its answer read as a stream.
  static absl::StatusOr<std::unique_ptr<SseStream>> Start(
      const std::string& address, const std::string& method, const std::string& path,
      const std::string& body, const std::map<std::string, std::string>& headers,
      absl::Duration timeout);
  ~SseStream();

  const HttpResponse& response() const { return response_; }
  // Reads until `count` events have arrived in all (true), or the stream
  // ends or `timeout` passes (false).
  bool ReadEvents(size_t count, absl::Duration timeout);
  // Reads until the stream ends (true) or `timeout` passes (false).
  bool ReadAll(absl::Duration timeout);
  const std::vector<SseEvent>& events() const { return events_; }
  int retry_ms() const { return retry_ms_; }
  bool ended() const { return ended_; }
  // Closes the connection (the gateway notices at its next write).
  void Close();

 private:
  SseStream() = default;
  // Reads what comes before `deadline` into the body; false at the end.
  bool ReadMore(absl::Time deadline);
  // Removes the chunk framing of raw_ into text_ and all_, then Parse().
  void Decode();
  // Turns the complete lines of text_ into events.
  void Parse();

  int fd_ = -1;
  HttpResponse response_;
  bool chunked_ = false;
  std::string raw_;    // bytes after the headers, still chunk-framed
  std::string text_;   // de-chunked body not yet parsed as events
  std::string all_;    // the whole de-chunked body
  int64_t content_length_ = -1;
  bool ended_ = false;
  std::vector<SseEvent> events_;
  SseEvent pending_;
  bool pending_has_data_ = false;
  int retry_ms_ = -1;
};

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_WEB_HTTP_TEST_CLIENT_H_
