// `riskplan-tool import`: a map bundle from real geodata (geo/map_importer.h).
#ifndef RISKPLAN_TOOLS_IMPORT_COMMAND_H_
#define RISKPLAN_TOOLS_IMPORT_COMMAND_H_

#include "cmdline/help.h"

namespace riskplan {

// The command's entry in riskplan-tool's help table.
cmdline::CommandHelp ImportCommandHelp();

// Runs the command from the parsed flags; `argc`/`argv` are recorded in the
// bundle's provenance. Returns the exit code (0, or 1/2 after printing the
// error as riskplan-tool does).
int ImportCommand(int argc, char** argv);

}  // namespace riskplan

#endif  // RISKPLAN_TOOLS_IMPORT_COMMAND_H_
