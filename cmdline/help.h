// Command-line help shared by every riskplan program: `--help` that exits 0
// and lists the program's own flags with their defaults, and for a program
// with commands (`riskplan plan`, `riskplan-tool info`) the flags of one
// command.
//
// Abseil's own --help lists the flags of every linked file under their build
// paths and exits 1; ParseCommandLine below answers every --help form itself,
// before Abseil sees it, from the flag registry (names, defaults and help
// texts, never file names) and a table the program writes: its commands and
// the flags each reads.
//
// Depends on Abseil only, so every program may use it (docs/architecture.md).
#ifndef RISKPLAN_CMDLINE_HELP_H_
#define RISKPLAN_CMDLINE_HELP_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace riskplan::cmdline {

// One command of a program that has commands.
struct CommandHelp {
  std::string name;     // as typed: "plan"
  std::string summary;  // one line, for the program's list of commands
  std::string usage;    // more lines for `PROG NAME --help` (synopsis, examples); may be empty
  // Every flag the command reads, without dashes, in the order shown. A
  // help text that starts with a list of commands ("plan: ", "eval, load: ")
  // is shown without it here.
  std::vector<std::string> flags;
};

// What a program's help says. In the program's own texts (usage, footer,
// a command's summary and usage) a line longer than 80 columns is wrapped,
// unless it is indented: synopses and examples are kept whole, to be copied.
struct ProgramHelp {
  std::string program;  // as typed: "riskplan"
  std::string usage;    // what the program is and how to call it, first in every help
  std::vector<CommandHelp> commands = {};  // empty for a program without commands
  std::string footer = {};                 // after the flags (examples, exit codes); may be empty
};

// A request for help on a command line.
struct HelpRequest {
  std::string command;  // the command asked about; empty: the whole program
  bool full = false;    // --helpfull: Abseil's own flags too
};

// Finds a request for help among argv[1..argc) before a "--": --help, -h,
// --helpshort, --helpfull, --helppackage, --helpon=X, --helpmatch=X (one or
// two dashes). The command asked about is the first argument that names one
// of help.commands, or X when it names one.
std::optional<HelpRequest> FindHelpRequest(int argc, char* const* argv, const ProgramHelp& help);

// The whole program's help: usage, its commands, every flag of the program
// (alphabetically, with its default and help text), footer; with `full`,
// Abseil's own flags (--flagfile, --fromenv, ...) too. A program's flags are
// all registered flags but Abseil's.
std::string ProgramHelpText(const ProgramHelp& help, bool full);

// The usage and the commands only, no flags: what a program with commands
// prints when it is given none.
std::string BriefHelpText(const ProgramHelp& help);

// One command's help: its summary and usage, then the flags it reads in the
// order of its table. NotFound for a command the table does not hold.
absl::StatusOr<std::string> CommandHelpText(const ProgramHelp& help, absl::string_view command);

// Checks the table against the flag registry: every flag a command names is
// defined, and every flag of a program with commands is read by at least one
// of them (so that no flag is missing from every command's help). The error
// names the flags at fault.
absl::Status CheckHelp(const ProgramHelp& help);

// Parses the command line with absl::ParseCommandLine (a flag it does not
// know, or a bad value, is reported naming the flag and exits 1), after
// answering a request for help (FindHelpRequest): the help goes to stdout and
// the program exits 0, or 1 (with the error on stderr) when CheckHelp fails,
// which is a bug of the program. --version prints the program's name and
// riskplan's version (exit 0). Returns the positional arguments, argv[0]
// first.
std::vector<char*> ParseCommandLine(int argc, char** argv, const ProgramHelp& help);

// ParseCommandLine for a program with commands, returning the command, which
// is the one positional argument. `PROG help` prints the program's help and
// `PROG help COMMAND` the command's (stdout, exit 0). No command prints
// BriefHelpText on stderr and exits 2; so do an unknown command and a second
// positional argument, each with a message naming it.
// REQUIRES: !help.commands.empty().
std::string ParseCommand(int argc, char** argv, const ProgramHelp& help);

}  // namespace riskplan::cmdline

#endif  // RISKPLAN_CMDLINE_HELP_H_
