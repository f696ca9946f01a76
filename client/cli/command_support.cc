#include "client/cli/command_support.h"

#include <cmath>
#include <cstdio>

#include "absl/strings/str_format.h"
#include "google/protobuf/util/json_util.h"

// The commands behind `riskplan` build their requests from CliOptions and
// check the options before the first call, so a mistyped flag costs no
// server time and exits 2, while a failed call exits 1 (the codes of
// commands.h): a script can tell its own mistakes from the server's.
// Validation is left to the server wherever it knows more (ranges, planner
// parameter names, admissibility), so a newer server needs no newer client.

namespace riskplan::client {

int Usage(const std::string& message) {
  std::fprintf(stderr, "riskplan: %s\n", message.c_str());
  return 2;
}

// The code by name, as docs/api.md lists the codes with their meaning and
// whether a retry can help.
// A failure to connect or a refusal comes with what it most likely means
// (ExplainStatus: which side refused the handshake, a token, a role).
int RpcError(const CliOptions& o, const char* method, const grpc::Status& status) {
  std::fprintf(stderr, "riskplan: %s failed: %s: %s\n", method,
               StatusCodeName(status.error_code()).c_str(),
               ExplainStatus(status, o.connection).c_str());
  return 1;
}

// --timeout_ms=0 (the default) means "the command's own deadline", which
// differs by command (riskplan_main.cc's help lists them).
absl::Duration TimeoutOr(const CliOptions& o, absl::Duration fallback) {
  return o.timeout > absl::ZeroDuration() ? o.timeout : fallback;
}

// The proto3 JSON mapping, with the proto's own field names (sample_count,
// not sampleCount) so that --json output matches the proto and the docs.
// 64-bit integers come out as strings, as the mapping requires (a double
// cannot hold them all). Printing fails only for an Any of an unknown type,
// and the API has no Any field, so the status is ignored.
std::string ToJson(const google::protobuf::Message& message) {
  std::string out;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(message, &out, options);
  return out;
}

// Checked before planning, not after a plan of many seconds that would then
// be lost.
absl::Status CheckPictureName(const CliOptions& o) {
  if (!o.picture.empty() && !o.picture.ends_with(".svg") && !o.picture.ends_with(".png")) {
    return absl::InvalidArgumentError("--picture must name a .svg or .png file");
  }
  return absl::OkStatus();
}

absl::StatusOr<ExportFiles> ExportsFromOptions(const CliOptions& o) {
  if (!(o.target_level_of_safety > 0.0) || !std::isfinite(o.target_level_of_safety)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--target_level_of_safety=%g: must be finite and > 0 (expected casualties per flight "
        "hour)",
        o.target_level_of_safety));
  }
  ExportFiles files = o.exports;
  if (absl::Status s = CheckExportFiles(o.plan_firmware, &files); !s.ok()) return s;
  return files;
}

int ExportError(const absl::Status& status) {
  std::fprintf(stderr, "riskplan: %s\n", std::string(status.message()).c_str());
  return absl::IsUnavailable(status) ? 1 : 2;
}

int Export(const ExportFiles& files, const v1::EvaluateRiskResponse& response,
           const std::string& map, const std::string& description, bool quiet) {
  absl::StatusOr<geo::ExportTrajectory> trajectory =
      ExportTrajectoryOf(response, map, description, files.spacing_m);
  if (!trajectory.ok()) return ExportError(trajectory.status());
  if (absl::Status s = WriteExports(files, *trajectory, quiet); !s.ok()) return ExportError(s);
  return 0;
}

// The map's landing sites and the picture's layers, fetched before the plan
// so that a plan cut short by the server's end can still be drawn. The layers
// are downsampled by the server to the picture's size: a full layer is 4
// bytes a map cell, far more than a picture of a few hundred pixels needs.
// Both are asked for at the same size, so they come on the same grid.
int FetchPictureLayers(const CliOptions& o, RiskplanClient& client, PictureInput* picture) {
  v1::ListMapsResponse maps;
  if (grpc::Status s = client.ListMaps(&maps); !s.ok()) return RpcError(o, "ListMaps", s);
  for (const v1::MapInfo& m : maps.maps()) {
    if (m.name() == o.map) picture->map = m;
  }
  v1::GetMapLayerRequest layer;
  layer.set_map(o.map);
  layer.set_max_side_cells(o.picture_size);
  layer.set_layer(v1::POPULATION_DENSITY);
  if (grpc::Status s = client.GetMapLayer(layer, &picture->density); !s.ok()) {
    return RpcError(o, "GetMapLayer", s);
  }
  layer.set_layer(v1::NO_FLY);
  if (grpc::Status s = client.GetMapLayer(layer, &picture->nofly); !s.ok()) {
    return RpcError(o, "GetMapLayer", s);
  }
  return 0;
}

}  // namespace riskplan::client
