#include "client/flight_link.h"

#include <utility>

#include "absl/time/clock.h"

namespace riskplan::client {

FlightLink::FlightLink(std::shared_ptr<grpc::Channel> channel, v1::FlightOpen open,
                       OutputCallback on_output, ReconnectCallback on_reconnect,
                       FlightLinkOptions options)
    : channel_(std::move(channel)),
      stub_(v1::Planner::NewStub(channel_)),
      open_(std::move(open)),
      on_output_(std::move(on_output)),
      on_reconnect_(std::move(on_reconnect)),
      options_(options) {
  for (const v1::FlightZone& z : open_.zones()) zones_[z.id()] = z;
  time_s_ = open_.time_s();
}

FlightLink::~FlightLink() {
  absl::MutexLock lock(&mu_);
  if (stream_ != nullptr) {
    stream_->ctx.TryCancel();
    CloseStream();
  }
}

grpc::Status FlightLink::Open() {
  absl::MutexLock lock(&mu_);
  return OpenStream(open_);
}

grpc::Status FlightLink::OpenStream(const v1::FlightOpen& open) {
  auto stream = std::make_unique<Stream>();
  stream->rw = stub_->Fly(&stream->ctx);
  v1::FlightInput in;
  *in.mutable_open() = open;
  if (!stream->rw->Write(in)) {
    grpc::Status status = stream->rw->Finish();
    return status.ok() ? grpc::Status(grpc::StatusCode::UNAVAILABLE, "the stream closed") : status;
  }
  const int number = ++streams_;
  {
    absl::MutexLock lock(&state_mu_);
    broken_ = false;
    ended_status_.reset();
  }
  Stream* raw = stream.get();
  stream->reader = std::thread([this, raw, number] { ReadLoop(raw, number); });
  stream_ = std::move(stream);
  return grpc::Status::OK;
}

void FlightLink::ReadLoop(Stream* stream, int number) {
  v1::FlightOutput out;
  while (stream->rw->Read(&out)) {
    if (out.has_plan()) {
      absl::MutexLock lock(&state_mu_);
      latest_ = out.plan();
    }
    if (on_output_) on_output_(number, out);
  }
  stream->status = stream->rw->Finish();
  absl::MutexLock lock(&state_mu_);
  stream->done = true;
  broken_ = true;
  ended_status_ = stream->status;
}

grpc::Status FlightLink::CloseStream() {
  if (stream_ == nullptr) return grpc::Status::OK;
  if (stream_->reader.joinable()) stream_->reader.join();
  grpc::Status status = stream_->status;
  stream_.reset();
  return status;
}

v1::FlightOpen FlightLink::ResumeOpen() const {
  v1::FlightOpen open = open_;
  open.set_resume(true);
  open.set_time_s(time_s_);
  open.clear_zones();
  for (const auto& [id, zone] : zones_) *open.add_zones() = zone;
  std::optional<v1::FlightPlanVersion> latest;
  {
    absl::MutexLock lock(&state_mu_);
    latest = latest_;
  }
  if (latest.has_value() && latest->committed_size() > 0) {
    *open.mutable_plan()->mutable_start() = latest->committed(0);
    *open.mutable_route() = latest->committed();
    for (int k = 1; k < latest->remainder().waypoints_size(); ++k) {
      *open.add_route() = latest->remainder().waypoints(k);
    }
    open.set_committed_count(static_cast<uint32_t>(latest->committed_size()));
    open.set_progress_m(progress_m_.value_or(latest->progress_m()));
  }
  return open;
}

grpc::Status FlightLink::Reconnect(const grpc::Status& why) {
  grpc::Status status = why;
  absl::Duration backoff = options_.first_backoff;
  while (reconnects_ < options_.max_reconnects) {
    ++reconnects_;
    if (on_reconnect_) on_reconnect_(streams_ + 1, status);
    status = OpenStream(ResumeOpen());
    if (status.ok() && wind_.has_value()) {
      v1::FlightInput in;
      *in.mutable_wind() = *wind_;
      if (!stream_->rw->Write(in)) status = grpc::Status(grpc::StatusCode::UNAVAILABLE, "broke");
    }
    if (status.ok()) return status;
    if (stream_ != nullptr) {
      stream_->ctx.TryCancel();
      CloseStream();
    }
    absl::SleepFor(backoff);
    backoff *= 2;
  }
  return status;
}

void FlightLink::Track(const v1::FlightInput& input) {
  switch (input.kind_case()) {
    case v1::FlightInput::kPosition:
      time_s_ = input.position().time_s();
      if (input.position().where_case() == v1::PositionReport::kProgressM) {
        progress_m_ = input.position().progress_m();
      } else {
        progress_m_.reset();
      }
      break;
    case v1::FlightInput::kAddZone:
      zones_[input.add_zone().id()] = input.add_zone();
      break;
    case v1::FlightInput::kRemoveZone:
      zones_.erase(input.remove_zone().id());
      break;
    case v1::FlightInput::kWind:
      wind_ = input.wind();
      break;
    default:
      break;
  }
}

grpc::Status FlightLink::Send(const v1::FlightInput& input) {
  absl::MutexLock lock(&mu_);
  for (int attempt = 0; attempt < 2; ++attempt) {
    bool broken = false;
    {
      absl::MutexLock state(&state_mu_);
      broken = broken_;
    }
    if (stream_ == nullptr || broken) {
      grpc::Status why = CloseStream();
      // A refusal of the session itself (its opening) is not a broken link.
      if (why.error_code() == grpc::StatusCode::INVALID_ARGUMENT ||
          why.error_code() == grpc::StatusCode::NOT_FOUND ||
          why.error_code() == grpc::StatusCode::PERMISSION_DENIED ||
          why.error_code() == grpc::StatusCode::UNAUTHENTICATED) {
        return why;
      }
      if (grpc::Status s = Reconnect(why); !s.ok()) return s;
    }
    if (stream_->rw->Write(input)) {
      Track(input);
      return grpc::Status::OK;
    }
    absl::MutexLock state(&state_mu_);
    broken_ = true;
  }
  return grpc::Status(grpc::StatusCode::UNAVAILABLE, "the flight's stream keeps breaking");
}

grpc::Status FlightLink::End() {
  absl::MutexLock lock(&mu_);
  if (stream_ == nullptr) return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, "not open");
  v1::FlightInput end;
  end.mutable_end();
  stream_->rw->Write(end);
  stream_->rw->WritesDone();
  return CloseStream();
}

void FlightLink::Break() {
  absl::MutexLock lock(&mu_);
  if (stream_ != nullptr) stream_->ctx.TryCancel();
}

std::optional<v1::FlightPlanVersion> FlightLink::latest() const {
  absl::MutexLock lock(&state_mu_);
  return latest_;
}

std::optional<grpc::Status> FlightLink::ended_status() const {
  absl::MutexLock lock(&state_mu_);
  return ended_status_;
}

int FlightLink::streams() const {
  absl::MutexLock lock(&mu_);
  return streams_;
}

}  // namespace riskplan::client
