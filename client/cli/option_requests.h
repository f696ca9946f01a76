// The API requests that the `riskplan` options describe: `eval`'s and
// `plan`'s, which `load --rpc=eval|plan` sends too and a missions file
// (fleet_file.h) builds each mission's from. The text forms are parsed here
// (client/trajectory_text.h); errors are InvalidArgument and name the flag
// at fault.
#ifndef RISKPLAN_CLIENT_CLI_OPTION_REQUESTS_H_
#define RISKPLAN_CLIENT_CLI_OPTION_REQUESTS_H_

#include "absl/status/statusor.h"
#include "client/cli/command_options.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

// The EvaluateRiskRequest of the eval flags (`riskplan eval`): exactly one
// trajectory (--waypoints, --polyline or --trajectory_file), the model
// parameters and the two-tier check.
absl::StatusOr<v1::EvaluateRiskRequest> EvalRequestFromOptions(const CliOptions& options);
// The PlanRequest of the plan flags (`riskplan plan`).
absl::StatusOr<v1::PlanRequest> PlanRequestFromOptions(const CliOptions& options);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CLI_OPTION_REQUESTS_H_
