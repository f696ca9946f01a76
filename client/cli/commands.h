// The `riskplan` CLI's commands, one file each (client/cli/*_command.cc),
// with their options already parsed from flags (riskplan_main.cc). Each
// prints to stdout (results, progress) and stderr (errors), and returns the
// process exit code:
//   0  success;
//   1  the RPC failed (the status code and message are printed; a `plan`
//      whose stream broke still writes the best trajectory it received);
//   2  bad command-line input;
//   3  `plan`: the plan ended without a trajectory (NO_SOLUTION, SHUTDOWN);
//      `fleet`: a mission ended without a trajectory or with its own error;
//      `fly`: the flight ended with an alert in force.
#ifndef RISKPLAN_CLIENT_CLI_COMMANDS_H_
#define RISKPLAN_CLIENT_CLI_COMMANDS_H_

#include "client/cli/command_options.h"
#include "client/client.h"

namespace riskplan::client {

int RunMaps(const CliOptions& options, RiskplanClient& client);
int RunEval(const CliOptions& options, RiskplanClient& client);
int RunPlan(const CliOptions& options, RiskplanClient& client);
// `riskplan plan --mission=FILE.plan` (client/cli/mission_command.cc).
int RunMission(const CliOptions& options, RiskplanClient& client);
int RunLoad(const CliOptions& options, RiskplanClient& client);
int RunFleet(const CliOptions& options, RiskplanClient& client);
int RunFly(const CliOptions& options, RiskplanClient& client);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CLI_COMMANDS_H_
