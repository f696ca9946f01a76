#include "accel/shim/shim_session.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace riskplan::accel {
namespace {

// Border of the quantised maps: windows up to this half width read without
// bounds checks (wider ones still work, cell by cell).
constexpr int kMapPad = 32;

}  // namespace

absl::Status BlobStore::Install(BlobKind kind, const BlobHash& hash, absl::string_view bytes) {
  if (Sha256(bytes) != hash) return absl::InvalidArgumentError("blob: SHA-256 does not match");
  Entry entry;
  if (kind == BlobKind::kMap) {
    absl::StatusOr<QuantizedMap> map = QuantizeMapBlob(bytes, format_, kMapPad);
    if (!map.ok()) return map.status();
    entry.bytes = map->MemoryBytes();
    entry.map = std::make_shared<const QuantizedMap>(*std::move(map));
  } else if (kind == BlobKind::kKernels) {
    absl::StatusOr<QuantizedKernelTable> table =
        QuantizeKernelsBlob(bytes, format_, max_kernel_side_);
    if (!table.ok()) return table.status();
    entry.bytes = table->MemoryBytes();
    absl::MutexLock lock(&mu_);
    table->id = next_table_id_++;
    entry.kernels = std::make_shared<const QuantizedKernelTable>(*std::move(table));
  } else {
    return absl::InvalidArgumentError("blob: unknown kind");
  }
  if (entry.bytes > capacity_bytes_) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "blob of %d bytes once quantised exceeds the store's %d", entry.bytes, capacity_bytes_));
  }
  absl::MutexLock lock(&mu_);
  // Quantised outside the lock: another connection may have installed the
  // same blob meanwhile.
  if (entries_.count(hash) != 0) return absl::OkStatus();
  MakeRoom(entry.bytes);
  entry.last_use = ++clock_;
  bytes_ += entry.bytes;
  entries_.emplace(hash, std::move(entry));
  return absl::OkStatus();
}

void BlobStore::MakeRoom(uint64_t bytes) {
  while (!entries_.empty() && bytes_ + bytes > capacity_bytes_) {
    auto oldest = entries_.begin();
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->second.last_use < oldest->second.last_use) oldest = it;
    }
    bytes_ -= oldest->second.bytes;
    entries_.erase(oldest);
  }
}

std::shared_ptr<const QuantizedMap> BlobStore::Map(const BlobHash& hash) {
  absl::MutexLock lock(&mu_);
  auto it = entries_.find(hash);
  if (it == entries_.end() || it->second.map == nullptr) return nullptr;
  it->second.last_use = ++clock_;
  return it->second.map;
}

std::shared_ptr<const QuantizedKernelTable> BlobStore::Kernels(const BlobHash& hash) {
  absl::MutexLock lock(&mu_);
  auto it = entries_.find(hash);
  if (it == entries_.end() || it->second.kernels == nullptr) return nullptr;
  it->second.last_use = ++clock_;
  return it->second.kernels;
}

uint64_t BlobStore::MemoryBytes() const {
  absl::MutexLock lock(&mu_);
  return bytes_;
}

std::string ShimSession::ErrorFrame(uint64_t id, ShimErrorCode code, absl::string_view message,
                                    const BlobHash& blob) {
  ErrorMessage e;
  e.code = code;
  // The protocol's strings are at most 4096 bytes.
  e.message = std::string(message.substr(0, 4000));
  e.blob = blob;
  return EncodeFrame(MessageType::kError, id, EncodeError(e));
}

std::string ShimSession::Handle(const FrameHeader& header, absl::string_view payload, bool* close) {
  *close = false;
  if (header.version != kShimProtocolVersion) {
    // Refused in this shim's own version: ERROR's layout is the same in
    // every version, so the client can read the refusal.
    *close = true;
    return ErrorFrame(header.request_id, ShimErrorCode::kVersionMismatch,
                      absl::StrFormat("this shim speaks protocol version %d only, not %d",
                                      kShimProtocolVersion, header.version));
  }
  switch (header.type) {
    case MessageType::kHello:
      return HandleHello(header.request_id, payload, close);
    case MessageType::kPing: {
      PingMessage ping;
      if (!DecodePing(payload, &ping).ok()) break;
      return EncodeFrame(MessageType::kPong, header.request_id, EncodePing(ping));
    }
    case MessageType::kPutBlob:
      return HandlePutBlob(header.request_id, payload, close);
    case MessageType::kEval:
      return HandleEval(header.request_id, payload, close);
    default:
      break;
  }
  *close = true;
  return ErrorFrame(header.request_id, ShimErrorCode::kMalformed,
                    absl::StrCat("cannot handle a ", MessageTypeName(header.type), " request"));
}

std::string ShimSession::HandleHello(uint64_t id, absl::string_view payload, bool* close) {
  HelloRequest hello;
  if (!DecodeHello(payload, &hello).ok()) {
    *close = true;
    return ErrorFrame(id, ShimErrorCode::kMalformed, "malformed HELLO");
  }
  const DeviceInfo& info = context_->device->info();
  HelloReply reply;
  reply.backend = info.backend;
  reply.device = info.device;
  reply.firmware = info.firmware;
  reply.format = info.format;
  reply.lanes = info.lanes;
  reply.max_sites_per_eval = context_->limits.max_sites_per_eval;
  reply.max_payload_bytes = context_->limits.max_payload_bytes;
  reply.max_kernel_side = info.max_kernel_side;
  reply.store_bytes = context_->limits.store_bytes;
  reply.clock_hz = info.clock_hz;
  return EncodeFrame(MessageType::kHelloReply, id, EncodeHelloReply(reply));
}

std::string ShimSession::HandlePutBlob(uint64_t id, absl::string_view payload, bool* close) {
  PutBlobRequest put;
  if (!DecodePutBlob(payload, &put).ok()) {
    *close = true;
    return ErrorFrame(id, ShimErrorCode::kMalformed, "malformed PUT_BLOB");
  }
  if (put.total_bytes > context_->limits.max_blob_bytes) {
    return ErrorFrame(id, ShimErrorCode::kLimitExceeded,
                      absl::StrFormat("blob of %d bytes exceeds the limit of %d", put.total_bytes,
                                      context_->limits.max_blob_bytes));
  }
  if (put.offset == 0) {
    // A new upload replaces any unfinished one.
    upload_hash_ = put.hash;
    upload_kind_ = put.kind;
    upload_total_ = put.total_bytes;
    upload_bytes_.clear();
    upload_bytes_.reserve(put.total_bytes);
  }
  if (put.hash != upload_hash_ || put.kind != upload_kind_ || put.total_bytes != upload_total_ ||
      put.offset != upload_bytes_.size() || put.offset + put.data.size() > put.total_bytes) {
    return ErrorFrame(id, ShimErrorCode::kBlobRejected,
                      absl::StrFormat("PUT_BLOB chunk at %d does not continue the upload (%d of "
                                      "%d bytes held)",
                                      put.offset, upload_bytes_.size(), upload_total_));
  }
  upload_bytes_.append(put.data);
  PutBlobReply reply;
  reply.hash = put.hash;
  reply.received_bytes = upload_bytes_.size();
  if (upload_bytes_.size() == upload_total_) {
    absl::Status s = context_->store->Install(upload_kind_, upload_hash_, upload_bytes_);
    upload_bytes_.clear();
    upload_bytes_.shrink_to_fit();
    if (!s.ok()) {
      return ErrorFrame(id,
                        s.code() == absl::StatusCode::kResourceExhausted
                            ? ShimErrorCode::kLimitExceeded
                            : ShimErrorCode::kBlobRejected,
                        s.message());
    }
    reply.complete = true;
  }
  return EncodeFrame(MessageType::kPutBlobReply, id, EncodePutBlobReply(reply));
}

std::string ShimSession::HandleEval(uint64_t id, absl::string_view payload, bool* close) {
  EvalRequest eval;
  if (!DecodeEval(payload, &eval).ok()) {
    *close = true;
    return ErrorFrame(id, ShimErrorCode::kMalformed, "malformed EVAL");
  }
  if (eval.sites.size() > context_->limits.max_sites_per_eval) {
    return ErrorFrame(id, ShimErrorCode::kLimitExceeded,
                      absl::StrFormat("EVAL of %d sites exceeds the limit of %d", eval.sites.size(),
                                      context_->limits.max_sites_per_eval));
  }
  std::shared_ptr<const QuantizedMap> map = context_->store->Map(eval.map);
  if (map == nullptr) {
    return ErrorFrame(id, ShimErrorCode::kUnknownBlob,
                      absl::StrCat("no map blob ", HashHex(eval.map)), eval.map);
  }
  std::shared_ptr<const QuantizedKernelTable> kernels = context_->store->Kernels(eval.kernels);
  if (kernels == nullptr) {
    return ErrorFrame(id, ShimErrorCode::kUnknownBlob,
                      absl::StrCat("no kernels blob ", HashHex(eval.kernels)), eval.kernels);
  }
  for (const DeviceSite& s : eval.sites) {
    // Impact cells beyond +-2^24 would only be reached by nonsense; they are
    // refused so that no device arithmetic on them can overflow.
    if (s.height_bin < 1 || s.height_bin > kernels->height_bins ||
        s.heading_bin >= kernels->heading_bins || s.impact_i < -(1 << 24) ||
        s.impact_i > (1 << 24) || s.impact_j < -(1 << 24) || s.impact_j > (1 << 24)) {
      return ErrorFrame(id, ShimErrorCode::kMalformed,
                        absl::StrFormat("site (%d, %d, %d, %d) outside the kernel table",
                                        s.height_bin, s.heading_bin, s.impact_i, s.impact_j));
    }
  }
  EvalReply reply;
  reply.impact_scale = context_->device->info().format.weight_frac_bits + map->density_exponent;
  reply.shelter_scale = context_->device->info().format.weight_frac_bits + map->shelter_exponent;
  reply.impact.resize(eval.sites.size());
  reply.shelter.resize(eval.sites.size());
  const auto start = std::chrono::steady_clock::now();
  absl::Status s;
  {
    // Each connection has its session; device access is serialised.
    absl::MutexLock lock(&context_->device_mu);
    s = context_->device->Evaluate(*map, *kernels, eval.sites, reply.impact, reply.shelter,
                                   &reply.device_cycles);
  }
  reply.device_ns = static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start)
          .count());
  if (!s.ok()) return ErrorFrame(id, ShimErrorCode::kDeviceError, s.message());
  context_->evals.fetch_add(1, std::memory_order_relaxed);
  context_->sites.fetch_add(eval.sites.size(), std::memory_order_relaxed);
  context_->device_cycles.fetch_add(reply.device_cycles, std::memory_order_relaxed);
  return EncodeFrame(MessageType::kEvalReply, id, EncodeEvalReply(reply));
}

}  // namespace riskplan::accel
