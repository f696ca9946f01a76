// Who may call what: bearer tokens, roles per method, and the caller's
// identity for the RPC log and the metrics.
//
// Tokens. --token_file names a text file of token hashes, one per line:
//
//   # SHA-256 of the token (hex)                                   identity   role
//   9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08 ground-1   planner
//
// The file holds no token, only its SHA-256, so a leaked file (or a log of
// it) grants nothing. It is re-read when it changes (checked at most once a
// second, on the calls themselves); a change that does not parse is refused
// with a log event and the previous table stays in force. A client sends
// `authorization: Bearer TOKEN`.
//
// Roles, each with everything of the ones before it:
//   viewer    ListMaps, GetMapLayer, GetRiskLayer, EvaluateRisk, reflection
//   planner   + PlanTrajectory, PlanFleet
//   operator  + Ping (what `riskplan load` calls at rate)
// grpc.health.v1.Health is open to everyone, with or without a token.
//
// Where the check runs. On a TLS port, TokenAuthProcessor (gRPC's
// AuthMetadataProcessor) refuses a call without a valid token before any
// handler runs (UNAUTHENTICATED, reflection included, health left open;
// logged as event token_refused, rate-limited). gRPC
// aborts the process if a processor is set on a plaintext port, so there
// (loopback) the service's handlers make the same check themselves through
// Authorizer::Check, which every Planner handler calls first on every port:
// the processor's properties live on the connection's auth context, shared
// by every call of the connection, so they cannot say which token *this*
// call carried. Both give UNAUTHENTICATED for a missing or unknown token and
// PERMISSION_DENIED for a role that may not call the method.
//
// Thread-safe, all of it.
#ifndef RISKPLAN_SERVER_SECURITY_AUTH_H_
#define RISKPLAN_SERVER_SECURITY_AUTH_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>


#include "absl/base/thread_annotations.h"
#include "absl/strings/string_view.h"
#include "absl/container/flat_hash_map.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "grpcpp/security/auth_metadata_processor.h"
#include "grpcpp/server_context.h"
#include "grpcpp/support/status.h"

namespace riskplan::server {

enum class Role { kViewer = 1, kPlanner = 2, kOperator = 3 };

// "viewer", "planner", "operator".
absl::string_view RoleName(Role role);
std::optional<Role> ParseRole(absl::string_view name);

// The least role that may call `method`, given as a full path
// ("/riskplan.v1.Planner/Ping") or a Planner method's name ("Ping");
// nullopt when anyone may (health). An unknown method needs kOperator, so a
// method added later is closed until it is given a role here.
std::optional<Role> RequiredRole(absl::string_view method);

// The SHA-256 of `token`, lower-case hex (what the token file holds).
std::string TokenHash(absl::string_view token);

struct TokenEntry {
  std::string identity;
  Role role = Role::kViewer;
};

class TokenStore {
 public:
  // Reads `path`. Errors name the file and the line.
  static absl::StatusOr<std::shared_ptr<TokenStore>> Load(const std::string& path);

  // The entry of `token`, or nullopt. Re-reads the file first if it changed
  // since it was last read (looked at most once per second).
  std::optional<TokenEntry> Find(absl::string_view token);

  const std::string& path() const { return path_; }
  // Entries now in force.
  size_t size() const;

 private:
  using Table = absl::flat_hash_map<std::string, TokenEntry>;  // by TokenHash
  struct Stamp {
    int64_t mtime_ns = 0, size = 0, inode = 0;
    bool operator==(const Stamp&) const = default;
  };
  explicit TokenStore(std::string path) : path_(std::move(path)) {}
  static absl::StatusOr<Table> Parse(const std::string& path, Stamp* stamp);
  void MaybeReload() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const std::string path_;
  mutable absl::Mutex mu_;
  Table table_ ABSL_GUARDED_BY(mu_);
  Stamp stamp_ ABSL_GUARDED_BY(mu_);
  absl::Time last_check_ ABSL_GUARDED_BY(mu_);
};

// At most kMaxIdentityLabels distinct values of a metrics label; later
// identities all count as "other", so that neither a large token file nor a
// CA that signs many client certificates can blow up the metrics.
inline constexpr size_t kMaxIdentityLabels = 64;
class IdentityLabels {
 public:
  // `identity` itself if it has a label or there is room for one, else
  // "other"; "anonymous" for "".
  std::string Label(const std::string& identity);

 private:
  absl::Mutex mu_;
  absl::flat_hash_map<std::string, bool> known_ ABSL_GUARDED_BY(mu_);
};

// Who made a call, as far as the server knows.
struct Caller {
  // The token's identity; else "x509:" and the client certificate's
  // subject (mutual TLS); else "" (anonymous). Goes into the RPC log line.
  std::string identity;
  // `identity` with bounded cardinality (IdentityLabels), for metrics.
  std::string label;
};

class Authorizer {
 public:
  // `tokens` null: no token is asked for (every call is allowed, and the
  // caller is known by its certificate only, if any).
  explicit Authorizer(std::shared_ptr<TokenStore> tokens) : tokens_(std::move(tokens)) {}

  bool requires_tokens() const { return tokens_ != nullptr; }

  // The decision for one call of `method` (as RequiredRole takes it) whose
  // `authorization` metadata is `authorization` (nullopt: none): OK,
  // UNAUTHENTICATED or PERMISSION_DENIED, with messages that never repeat
  // the token. Fills `caller->identity` with the token's identity.
  grpc::Status CheckToken(std::optional<absl::string_view> authorization, absl::string_view method,
                          Caller* caller) const;

  // CheckToken with the call's own metadata, and the caller's identity from
  // its certificate when it sent no token; sets `caller->label`.
  // REQUIRES: caller != nullptr.
  grpc::Status Check(const grpc::ServerContextBase& ctx, absl::string_view method, Caller* caller);

 private:
  const std::shared_ptr<TokenStore> tokens_;
  IdentityLabels labels_;
};

// The TLS ports' gate (see the top of this file). Never consumes the token:
// the handler checks it again for its role.
class TokenAuthProcessor final : public grpc::AuthMetadataProcessor {
 public:
  explicit TokenAuthProcessor(std::shared_ptr<Authorizer> authorizer)
      : authorizer_(std::move(authorizer)) {}
  // A hash lookup: cheap enough for gRPC's own thread.
  bool IsBlocking() const override { return false; }
  grpc::Status Process(const InputMetadata& auth_metadata, grpc::AuthContext* context,
                       OutputMetadata* consumed_auth_metadata,
                       OutputMetadata* response_metadata) override;

 private:
  const std::shared_ptr<Authorizer> authorizer_;
  absl::Mutex mu_;
  int64_t refused_ ABSL_GUARDED_BY(mu_) = 0;
  absl::Time last_logged_ ABSL_GUARDED_BY(mu_);
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SECURITY_AUTH_H_
