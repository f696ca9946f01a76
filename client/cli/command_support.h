// What the `riskplan` commands (client/cli/*_command.cc) share: their exit
// codes for bad input and failed calls (commands.h), their deadlines, --json
// output, the ground-station and GIS exports, and a picture's layers.
#ifndef RISKPLAN_CLIENT_CLI_COMMAND_SUPPORT_H_
#define RISKPLAN_CLIENT_CLI_COMMAND_SUPPORT_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/cli/command_options.h"
#include "client/client.h"
#include "client/exports.h"
#include "client/picture/picture.h"
#include "google/protobuf/message.h"

namespace riskplan::client {

// Prints "riskplan: MESSAGE"; returns 2, the exit code of bad input.
int Usage(const std::string& message);
// Prints "riskplan: METHOD failed: CODE: message (hint)"; returns 1.
int RpcError(const CliOptions& options, const char* method, const grpc::Status& status);

// --timeout_ms, or `fallback` when it is 0 (the default).
absl::Duration TimeoutOr(const CliOptions& options, absl::Duration fallback);

// `message` in the proto3 JSON mapping, as --json prints it.
std::string ToJson(const google::protobuf::Message& message);

// OK when --picture is empty or names a .svg or .png file.
absl::Status CheckPictureName(const CliOptions& options);

// The export options from the flags, checked before any call (with the
// target level of safety, which the same commands read).
absl::StatusOr<ExportFiles> ExportsFromOptions(const CliOptions& options);
// Prints why an export failed; returns its exit code: 2 when the input
// cannot be exported (a map without geo-reference), 1 when a file cannot be
// written.
int ExportError(const absl::Status& status);
// Exports the evaluation of a trajectory that has a path; 0, or the exit
// code of ExportError.
int Export(const ExportFiles& files, const v1::EvaluateRiskResponse& response,
           const std::string& map, const std::string& description, bool quiet = false);

// The map's landing sites and density and no-fly layers at --picture_size,
// into `picture`; 0, or the exit code of a failed call (printed).
int FetchPictureLayers(const CliOptions& options, RiskplanClient& client, PictureInput* picture);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CLI_COMMAND_SUPPORT_H_
