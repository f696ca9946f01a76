#include "server/security/auth.h"

#include <openssl/evp.h>
#include <sys/stat.h>

#include <array>
#include <fstream>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "grpc/grpc_security_constants.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {
namespace {

constexpr absl::Duration kReloadCheckEvery = absl::Seconds(1);
constexpr absl::string_view kPlannerService = "/riskplan.v1.Planner/";
constexpr absl::string_view kBearer = "Bearer ";

bool IsLowerHex(absl::string_view s) {
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace

absl::string_view RoleName(Role role) {
  switch (role) {
    case Role::kViewer:
      return "viewer";
    case Role::kPlanner:
      return "planner";
    case Role::kOperator:
      return "operator";
  }
  return "unknown";
}

std::optional<Role> ParseRole(absl::string_view name) {
  for (Role r : {Role::kViewer, Role::kPlanner, Role::kOperator}) {
    if (name == RoleName(r)) return r;
  }
  return std::nullopt;
}

std::optional<Role> RequiredRole(absl::string_view method) {
  if (absl::StartsWith(method, "/grpc.health.v1.Health/")) return std::nullopt;
  // Reflection tells the schema, which docs/api.md publishes anyway.
  if (absl::StartsWith(method, "/grpc.reflection.")) return Role::kViewer;
  if (absl::StartsWith(method, kPlannerService)) method.remove_prefix(kPlannerService.size());
  if (method == "ListMaps" || method == "GetMapLayer" || method == "GetRiskLayer" ||
      method == "EvaluateRisk") {
    return Role::kViewer;
  }
  if (method == "PlanTrajectory" || method == "PlanFleet" || method == "Fly") return Role::kPlanner;
  return Role::kOperator;  // Ping, and whatever is not listed yet
}

std::string TokenHash(absl::string_view token) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  EVP_Digest(token.data(), token.size(), digest.data(), &length, EVP_sha256(), nullptr);
  std::string hex;
  hex.reserve(2 * length);
  for (unsigned int i = 0; i < length; ++i) absl::StrAppendFormat(&hex, "%02x", digest[i]);
  return hex;
}

absl::StatusOr<TokenStore::Table> TokenStore::Parse(const std::string& path, Stamp* stamp) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    return absl::NotFoundError(absl::StrFormat("--token_file=%s: cannot read it", path));
  }
  *stamp = Stamp{.mtime_ns = int64_t{st.st_mtim.tv_sec} * 1000000000 + st.st_mtim.tv_nsec,
                 .size = st.st_size,
                 .inode = static_cast<int64_t>(st.st_ino)};
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrFormat("--token_file=%s: cannot read it", path));
  Table table;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    absl::string_view text = absl::StripAsciiWhitespace(line);
    if (text.empty() || text.front() == '#') continue;
    std::vector<absl::string_view> fields = absl::StrSplit(text, absl::ByAnyChar(" \t"),
                                                          absl::SkipEmpty());
    const auto error = [&](absl::string_view why) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--token_file=%s: line %d: %s", path, number, why));
    };
    if (fields.size() != 3) {
      return error("expected 'SHA256_HEX IDENTITY ROLE' (the token's SHA-256, never the token)");
    }
    if (fields[0].size() != 64 || !IsLowerHex(fields[0])) {
      return error("the first field must be a SHA-256 in 64 lower-case hex digits");
    }
    std::optional<Role> role = ParseRole(fields[2]);
    if (!role.has_value()) {
      return error(absl::StrCat("role '", fields[2], "' is not viewer, planner or operator"));
    }
    if (!table.emplace(fields[0], TokenEntry{std::string(fields[1]), *role}).second) {
      return error("this token hash is listed twice");
    }
  }
  return table;
}

absl::StatusOr<std::shared_ptr<TokenStore>> TokenStore::Load(const std::string& path) {
  std::shared_ptr<TokenStore> store(new TokenStore(path));
  Stamp stamp;
  absl::StatusOr<Table> table = Parse(path, &stamp);
  if (!table.ok()) return table.status();
  absl::MutexLock lock(&store->mu_);
  store->table_ = *std::move(table);
  store->stamp_ = stamp;
  store->last_check_ = absl::Now();
  return store;
}

void TokenStore::MaybeReload() {
  const absl::Time now = absl::Now();
  if (now - last_check_ < kReloadCheckEvery) return;
  last_check_ = now;
  struct stat st {};
  if (stat(path_.c_str(), &st) == 0 &&
      Stamp{.mtime_ns = int64_t{st.st_mtim.tv_sec} * 1000000000 + st.st_mtim.tv_nsec,
            .size = st.st_size,
            .inode = static_cast<int64_t>(st.st_ino)} == stamp_) {
    return;
  }
  Stamp stamp;
  absl::StatusOr<Table> table = Parse(path_, &stamp);
  if (!table.ok()) {
    // Kept: a half-written or broken file must not lock everyone out.
    LogEvent("token_file_rejected",
             absl::StrCat(table.status().message(), "; the previous tokens stay in force"));
    return;
  }
  table_ = *std::move(table);
  stamp_ = stamp;
  LogEvent("token_file_loaded", absl::StrFormat("path=%s tokens=%d", path_, table_.size()));
}

std::optional<TokenEntry> TokenStore::Find(absl::string_view token) {
  const std::string hash = TokenHash(token);
  absl::MutexLock lock(&mu_);
  MaybeReload();
  auto it = table_.find(hash);
  if (it == table_.end()) return std::nullopt;
  return it->second;
}

size_t TokenStore::size() const {
  absl::MutexLock lock(&mu_);
  return table_.size();
}

std::string IdentityLabels::Label(const std::string& identity) {
  if (identity.empty()) return "anonymous";
  absl::MutexLock lock(&mu_);
  if (known_.contains(identity)) return identity;
  if (known_.size() >= kMaxIdentityLabels) return "other";
  known_.emplace(identity, true);
  return identity;
}

grpc::Status Authorizer::CheckToken(std::optional<absl::string_view> authorization,
                                    absl::string_view method, Caller* caller) const {
  const std::optional<Role> required = RequiredRole(method);
  if (tokens_ == nullptr || !required.has_value()) return grpc::Status::OK;
  if (!authorization.has_value()) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "this server requires a bearer token (riskplan --token_file=FILE)");
  }
  absl::string_view value = *authorization;
  if (!absl::StartsWith(value, kBearer)) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "the authorization metadata is not 'Bearer TOKEN'");
  }
  value.remove_prefix(kBearer.size());
  std::optional<TokenEntry> entry = tokens_->Find(value);
  if (!entry.has_value()) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "the bearer token is not one this server knows (revoked, or mistyped)");
  }
  if (caller != nullptr) caller->identity = entry->identity;
  if (entry->role < *required) {
    absl::string_view name = method;
    if (absl::StartsWith(name, kPlannerService)) name.remove_prefix(kPlannerService.size());
    return grpc::Status(
        grpc::StatusCode::PERMISSION_DENIED,
        absl::StrFormat("%s has role %s; %s needs role %s or above", entry->identity,
                        RoleName(entry->role), name, RoleName(*required)));
  }
  return grpc::Status::OK;
}

grpc::Status Authorizer::Check(const grpc::ServerContextBase& ctx, absl::string_view method,
                               Caller* caller) {
  std::optional<absl::string_view> authorization;
  const auto& metadata = ctx.client_metadata();
  if (auto it = metadata.find("authorization"); it != metadata.end()) {
    authorization = absl::string_view(it->second.data(), it->second.size());
  }
  grpc::Status status = CheckToken(authorization, method, caller);
  if (caller->identity.empty()) {
    // No token: the client certificate's subject, when mutual TLS gave one.
    std::shared_ptr<const grpc::AuthContext> auth = ctx.auth_context();
    if (auth != nullptr) {
      std::vector<grpc::string_ref> subject = auth->FindPropertyValues(GRPC_X509_SUBJECT_PROPERTY_NAME);
      if (subject.empty()) subject = auth->FindPropertyValues(GRPC_X509_CN_PROPERTY_NAME);
      if (!subject.empty()) {
        caller->identity = absl::StrCat("x509:", absl::string_view(subject[0].data(), subject[0].size()));
      }
    }
  }
  caller->label = labels_.Label(caller->identity);
  return status;
}

grpc::Status TokenAuthProcessor::Process(const InputMetadata& auth_metadata,
                                         grpc::AuthContext* /*context*/,
                                         OutputMetadata* /*consumed_auth_metadata*/,
                                         OutputMetadata* /*response_metadata*/) {
  std::optional<absl::string_view> authorization;
  absl::string_view path;
  for (const auto& [key, value] : auth_metadata) {
    if (key == "authorization") authorization = absl::string_view(value.data(), value.size());
    if (key == ":path") path = absl::string_view(value.data(), value.size());
  }
  if (!RequiredRole(path).has_value()) return grpc::Status::OK;  // health
  // The token only (any role passes): the role is the handler's to check, so
  // that a PERMISSION_DENIED is an RPC log line with the caller's identity.
  // Reflection, which has no handler of ours, needs viewer, the least role.
  grpc::Status status = authorizer_->CheckToken(authorization, "ListMaps", nullptr);
  if (!status.ok()) {
    // No handler runs and no RPC line is written: counted here, and logged
    // at the first refusal and then at most every 10 s.
    absl::MutexLock lock(&mu_);
    ++refused_;
    const absl::Time now = absl::Now();
    if (refused_ == 1 || now - last_logged_ >= absl::Seconds(10)) {
      LogEvent("token_refused",
               absl::StrFormat("refused=%d last_method=%s reason=\"%s\"", refused_,
                               std::string(path), status.error_message()));
      last_logged_ = now;
    }
  }
  return status;
}

}  // namespace riskplan::server
