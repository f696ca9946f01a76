// Server reflection (grpc.reflection.v1alpha.ServerReflection), riskplan's
// own: the same protocol as gRPC's plugin, with the caller's token checked
// first, like every Planner method (a viewer method: server/security/auth.h).
//
// Why not gRPC's plugin: it has no handler of ours, so on a plaintext port
// (where gRPC 1.51 allows no AuthMetadataProcessor) nothing could check a
// token for it, and `InitProtoReflectionServerBuilderPlugin()` adds it to
// every server the process builds, the health port's included. This one is
// registered on the gRPC port alone (server/server_startup.cc).
//
// It answers from the process's generated descriptor pool: list_services
// (the services given), file_by_filename, file_containing_symbol,
// file_containing_extension and all_extension_numbers_of_type; a file is
// sent with the files it imports, each once per stream. Unknown names get
// the protocol's error_response (NOT_FOUND), as gRPC's own does.
//
// Thread-safe.
#ifndef RISKPLAN_SERVER_SECURITY_REFLECTION_SERVICE_H_
#define RISKPLAN_SERVER_SECURITY_REFLECTION_SERVICE_H_

#include <memory>
#include <string>
#include <vector>

#include "grpc/reflection/v1alpha/reflection.grpc.pb.h"
#include "server/security/auth.h"

namespace riskplan::server {

class ReflectionService final : public grpc::reflection::v1alpha::ServerReflection::Service {
 public:
  // `services`: the full names list_services answers. `authorizer` checks
  // every call (never null).
  ReflectionService(std::vector<std::string> services, std::shared_ptr<Authorizer> authorizer);

  grpc::Status ServerReflectionInfo(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<grpc::reflection::v1alpha::ServerReflectionResponse,
                               grpc::reflection::v1alpha::ServerReflectionRequest>* stream)
      override;

  static constexpr char kMethod[] =
      "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo";

 private:
  const std::vector<std::string> services_;
  const std::shared_ptr<Authorizer> authorizer_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SECURITY_REFLECTION_SERVICE_H_
