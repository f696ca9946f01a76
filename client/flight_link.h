// FlightLink: one in-flight session (the Fly stream, docs/in-flight.md) that
// outlives broken streams. Every output is passed to a callback on a reader
// thread; Send() writes an input, and when the stream has broken it first
// opens a new one (on any replica the channel's target names, round-robin)
// with FlightOpen.resume: the last plan version's committed prefix, the
// latest progress and time, the zones the client added and did not remove,
// then the latest wind. The session's versions start again at 1 on the new
// stream (FlightPlanVersion.resumed says so).
#ifndef RISKPLAN_CLIENT_FLIGHT_LINK_H_
#define RISKPLAN_CLIENT_FLIGHT_LINK_H_

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"

namespace riskplan::client {

struct FlightLinkOptions {
  int max_reconnects = 10;                                  // over the whole flight
  absl::Duration first_backoff = absl::Milliseconds(100);   // doubled after each failed attempt
};

class FlightLink {
 public:
  // Called on the reader thread for every output, with the number of the
  // stream it came on (1, then 2 after the first reconnection, ...).
  using OutputCallback = std::function<void(int stream, const v1::FlightOutput&)>;
  // Called when a stream breaks and the link opens another.
  using ReconnectCallback = std::function<void(int stream, const grpc::Status& why)>;

  FlightLink(std::shared_ptr<grpc::Channel> channel, v1::FlightOpen open, OutputCallback on_output,
             ReconnectCallback on_reconnect = {}, FlightLinkOptions options = {});
  ~FlightLink();

  FlightLink(const FlightLink&) = delete;
  FlightLink& operator=(const FlightLink&) = delete;

  // Opens the first stream with `open`.
  grpc::Status Open();
  // Writes `input` (not `open` or `end`), reconnecting first when the stream
  // broke. Fails when the session ended with an error the server gave (a
  // bad opening) or when every reconnection failed.
  grpc::Status Send(const v1::FlightInput& input);
  // Sends `end`, half-closes and waits for the last outputs; the status.
  grpc::Status End();
  // Breaks the stream as a failing link would (tests, scripted flights).
  void Break();

  // The status the current stream ended with, once its reader saw it end
  // (a refused opening: the server's INVALID_ARGUMENT naming the field);
  // nullopt while the stream is open.
  std::optional<grpc::Status> ended_status() const;
  // The latest plan version received (on any stream), if any.
  std::optional<v1::FlightPlanVersion> latest() const;
  int streams() const;

 private:
  struct Stream {
    grpc::ClientContext ctx;
    std::unique_ptr<grpc::ClientReaderWriter<v1::FlightInput, v1::FlightOutput>> rw;
    std::thread reader;
    grpc::Status status;
    bool done = false;  // the reader saw the stream end
  };

  // Opens stream number streams_ + 1 with `open`; the reader starts.
  grpc::Status OpenStream(const v1::FlightOpen& open) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // A resume opening from what the link knows.
  v1::FlightOpen ResumeOpen() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  grpc::Status Reconnect(const grpc::Status& why) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void ReadLoop(Stream* stream, int number);
  // Joins the reader of the current stream and returns its status.
  grpc::Status CloseStream() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void Track(const v1::FlightInput& input) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const std::shared_ptr<grpc::Channel> channel_;
  const std::unique_ptr<v1::Planner::Stub> stub_;
  const v1::FlightOpen open_;
  const OutputCallback on_output_;
  const ReconnectCallback on_reconnect_;
  const FlightLinkOptions options_;

  mutable absl::Mutex mu_;  // held by Send/End/Break; the reader takes state_mu_ only
  std::unique_ptr<Stream> stream_ ABSL_GUARDED_BY(mu_);
  int streams_ ABSL_GUARDED_BY(mu_) = 0;
  int reconnects_ ABSL_GUARDED_BY(mu_) = 0;
  // What a resume needs.
  std::map<std::string, v1::FlightZone> zones_ ABSL_GUARDED_BY(mu_);
  std::optional<v1::WindChange> wind_ ABSL_GUARDED_BY(mu_);
  double time_s_ ABSL_GUARDED_BY(mu_) = 0.0;
  std::optional<double> progress_m_ ABSL_GUARDED_BY(mu_);

  mutable absl::Mutex state_mu_;
  std::optional<v1::FlightPlanVersion> latest_ ABSL_GUARDED_BY(state_mu_);
  bool broken_ ABSL_GUARDED_BY(state_mu_) = false;
  std::optional<grpc::Status> ended_status_ ABSL_GUARDED_BY(state_mu_);
};

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_FLIGHT_LINK_H_
