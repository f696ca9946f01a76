#include "cmdline/help.h"

#include <algorithm>
#include <cassert>
#include <cstdio>
#include <cstdlib>

#include "absl/flags/commandlineflag.h"
#include "absl/flags/parse.h"
#include "absl/flags/reflection.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace riskplan::cmdline {
namespace {

// Abseil's --help family, all answered here. "h" is no Abseil flag: -h is
// what most people try first.
constexpr absl::string_view kHelpFlags[] = {"help",        "h",      "helpshort", "helpfull",
                                            "helppackage", "helpon", "helpmatch"};

// Help texts are wrapped to a terminal's 80 columns.
constexpr size_t kLineWidth = 80;
constexpr size_t kHelpIndent = 6;

const CommandHelp* FindCommand(const ProgramHelp& help, absl::string_view name) {
  for (const CommandHelp& c : help.commands) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

// Abseil's own flags (--flagfile, --fromenv, the --help family, ...) are
// defined in its flags library; everything else registered is the program's.
// The file name is only compared, never shown: it is a build path.
bool IsAbseilFlag(const absl::CommandLineFlag& flag) {
  return absl::StrContains(flag.Filename(), "absl/flags/");
}

std::vector<const absl::CommandLineFlag*> RegisteredFlags(bool abseil) {
  std::vector<const absl::CommandLineFlag*> flags;
  for (const auto& [name, flag] : absl::GetAllFlags()) {
    if (flag->IsRetired() || IsAbseilFlag(*flag) != abseil) continue;
    if (abseil &&
        std::find(std::begin(kHelpFlags), std::end(kHelpFlags), name) != std::end(kHelpFlags)) {
      continue;
    }
    flags.push_back(flag);
  }
  std::sort(flags.begin(), flags.end(),
            [](const auto* a, const auto* b) { return a->Name() < b->Name(); });
  return flags;
}

// "plan: time budget" -> "time budget" when every name before the colon is
// one of the program's commands: under a command's own heading the list only
// repeats which commands read the flag.
absl::string_view WithoutCommandList(absl::string_view text, const ProgramHelp& help) {
  const size_t colon = text.find(": ");
  if (colon == absl::string_view::npos) return text;
  for (absl::string_view name : absl::StrSplit(text.substr(0, colon), ',')) {
    if (FindCommand(help, absl::StripAsciiWhitespace(name)) == nullptr) return text;
  }
  return text.substr(colon + 2);
}

// Appends `text` word-wrapped at kLineWidth, every line indented by
// `indent`; the text's own line breaks are kept.
void AppendWrapped(std::string* out, absl::string_view text, size_t indent) {
  for (absl::string_view paragraph : absl::StrSplit(text, '\n')) {
    size_t column = 0;
    for (absl::string_view word : absl::StrSplit(paragraph, ' ', absl::SkipEmpty())) {
      if (column > 0 && column + 1 + word.size() > kLineWidth) {
        out->push_back('\n');
        column = 0;
      }
      if (column == 0) {
        out->append(indent, ' ');
        column = indent;
      } else {
        out->push_back(' ');
        ++column;
      }
      absl::StrAppend(out, word);
      column += word.size();
    }
    out->push_back('\n');
  }
}

// A program's own text (usage, footer): its prose lines wrapped, its
// indented lines (synopses, examples) kept as they are, to be copied.
void AppendText(std::string* out, absl::string_view text) {
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    if (absl::StartsWith(line, " ") || line.size() <= kLineWidth) {
      absl::StrAppend(out, line, "\n");
    } else {
      AppendWrapped(out, line, 0);
    }
  }
}

// "  --name=DEFAULT" and the help text under it. An empty default, or one
// with spaces, is quoted so that the line can be copied as it is.
void AppendFlag(std::string* out, const absl::CommandLineFlag& flag, absl::string_view text) {
  std::string value = flag.DefaultValue();
  if (value.empty() || absl::StrContains(value, ' ')) value = absl::StrCat("\"", value, "\"");
  absl::StrAppend(out, "  --", flag.Name(), "=", value, "\n");
  AppendWrapped(out, text, kHelpIndent);
}

void AppendCommands(std::string* out, const ProgramHelp& help) {
  size_t width = 0;
  for (const CommandHelp& c : help.commands) width = std::max(width, c.name.size());
  absl::StrAppend(out, "\nCommands (`", help.program,
                  " COMMAND --help` lists a command's flags):\n");
  for (const CommandHelp& c : help.commands) {
    absl::StrAppend(out, "  ", c.name, std::string(width + 2 - c.name.size(), ' '), c.summary,
                    "\n");
  }
}

// Prints the help asked for on stdout; 0, or 1 when the program's table is
// wrong (a bug the help tests catch).
int PrintHelp(const ProgramHelp& help, const HelpRequest& request) {
  std::string text;
  if (request.command.empty()) {
    text = ProgramHelpText(help, request.full);
  } else {
    absl::StatusOr<std::string> command = CommandHelpText(help, request.command);
    text = command.ok() ? *std::move(command) : ProgramHelpText(help, request.full);
  }
  std::fputs(text.c_str(), stdout);
  if (absl::Status s = CheckHelp(help); !s.ok()) {
    std::fprintf(stderr, "%s: the help's table is wrong: %s\n", help.program.c_str(),
                 std::string(s.message()).c_str());
    return 1;
  }
  return 0;
}

std::string CommandNames(const ProgramHelp& help) {
  return absl::StrJoin(help.commands, ", ",
                       [](std::string* out, const CommandHelp& c) { out->append(c.name); });
}

}  // namespace

std::optional<HelpRequest> FindHelpRequest(int argc, char* const* argv, const ProgramHelp& help) {
  std::optional<HelpRequest> request;
  std::string named_command;  // the first argument naming a command
  for (int i = 1; i < argc; ++i) {
    absl::string_view arg = argv[i];
    if (arg == "--") break;  // what follows is positional, even "--help"
    if (!absl::ConsumePrefix(&arg, "-")) {
      if (named_command.empty() && FindCommand(help, arg) != nullptr)
        named_command = std::string(arg);
      continue;
    }
    absl::ConsumePrefix(&arg, "-");
    const std::pair<absl::string_view, absl::string_view> name_value =
        absl::StrSplit(arg, absl::MaxSplits('=', 1));
    if (std::find(std::begin(kHelpFlags), std::end(kHelpFlags), name_value.first) ==
        std::end(kHelpFlags)) {
      continue;
    }
    if (!request.has_value()) request.emplace();
    request->full = request->full || name_value.first == "helpfull";
    // --help=plan, --helpon=plan: Abseil's way to narrow the help down.
    if (FindCommand(help, name_value.second) != nullptr) {
      request->command = std::string(name_value.second);
    }
  }
  if (request.has_value() && request->command.empty()) request->command = named_command;
  return request;
}

std::string ProgramHelpText(const ProgramHelp& help, bool full) {
  std::string out;
  AppendText(&out, absl::StrCat(help.program, ": ", help.usage));
  if (!help.commands.empty()) AppendCommands(&out, help);
  out += "\nFlags (each with its default):\n";
  for (const absl::CommandLineFlag* flag : RegisteredFlags(/*abseil=*/false)) {
    AppendFlag(&out, *flag, flag->Help());
  }
  if (!help.footer.empty()) AppendText(&out, absl::StrCat("\n", help.footer));
  if (full) {
    out += "\nFlags of the command-line parser (Abseil):\n";
    for (const absl::CommandLineFlag* flag : RegisteredFlags(/*abseil=*/true)) {
      AppendFlag(&out, *flag, flag->Help());
    }
  }
  return out;
}

std::string BriefHelpText(const ProgramHelp& help) {
  std::string out;
  AppendText(&out, absl::StrCat(help.program, ": ", help.usage));
  if (!help.commands.empty()) AppendCommands(&out, help);
  absl::StrAppend(&out, "\n`", help.program, " --help` lists every flag.\n");
  return out;
}

absl::StatusOr<std::string> CommandHelpText(const ProgramHelp& help, absl::string_view command) {
  const CommandHelp* c = FindCommand(help, command);
  if (c == nullptr) {
    return absl::NotFoundError(
        absl::StrCat("unknown command '", command, "'; the commands are ", CommandNames(help)));
  }
  std::string out;
  AppendText(&out, absl::StrCat(help.program, " ", c->name, ": ", c->summary));
  if (!c->usage.empty()) AppendText(&out, absl::StrCat("\n", c->usage));
  out += "\nFlags (each with its default):\n";
  for (const std::string& name : c->flags) {
    const absl::CommandLineFlag* flag = absl::FindCommandLineFlag(name);
    if (flag == nullptr) continue;  // CheckHelp reports it
    AppendFlag(&out, *flag, WithoutCommandList(flag->Help(), help));
  }
  return out;
}

absl::Status CheckHelp(const ProgramHelp& help) {
  std::vector<std::string> problems;
  for (const CommandHelp& c : help.commands) {
    for (const std::string& name : c.flags) {
      if (absl::FindCommandLineFlag(name) == nullptr) {
        problems.push_back(absl::StrCat(c.name, " names --", name, ", which is not defined"));
      }
    }
  }
  if (!help.commands.empty()) {
    for (const absl::CommandLineFlag* flag : RegisteredFlags(/*abseil=*/false)) {
      const bool read = std::any_of(help.commands.begin(), help.commands.end(), [&](const auto& c) {
        return std::find(c.flags.begin(), c.flags.end(), flag->Name()) != c.flags.end();
      });
      if (!read) problems.push_back(absl::StrCat("no command reads --", flag->Name()));
    }
  }
  if (problems.empty()) return absl::OkStatus();
  return absl::InternalError(absl::StrJoin(problems, "; "));
}

std::vector<char*> ParseCommandLine(int argc, char** argv, const ProgramHelp& help) {
  if (std::optional<HelpRequest> request = FindHelpRequest(argc, argv, help)) {
    std::exit(PrintHelp(help, *request));
  }
  // Abseil's --version would print the build type of the Abseil library
  // (Debian's says "Debug build"), not riskplan's version.
  for (int i = 1; i < argc && absl::string_view(argv[i]) != "--"; ++i) {
    if (absl::string_view(argv[i]) == "--version" || absl::string_view(argv[i]) == "-version") {
      std::printf("%s %s\n", help.program.c_str(), RISKPLAN_VERSION);
      std::exit(0);
    }
  }
  return absl::ParseCommandLine(argc, argv);
}

std::string ParseCommand(int argc, char** argv, const ProgramHelp& help) {
  assert(!help.commands.empty());
  const std::vector<char*> positional = ParseCommandLine(argc, argv, help);
  const char* program = help.program.c_str();
  if (positional.size() < 2) {
    std::fputs(BriefHelpText(help).c_str(), stderr);
    std::exit(2);
  }
  const std::string command = positional[1];
  if (command == "help" && positional.size() <= 3) {
    HelpRequest request;
    if (positional.size() == 3) request.command = positional[2];
    if (!request.command.empty() && FindCommand(help, request.command) == nullptr) {
      std::fprintf(stderr, "%s: unknown command '%s'; the commands are %s\n", program,
                   request.command.c_str(), CommandNames(help).c_str());
      std::exit(2);
    }
    std::exit(PrintHelp(help, request));
  }
  if (FindCommand(help, command) == nullptr) {
    std::fprintf(stderr, "%s: unknown command '%s'; the commands are %s (see %s --help)\n", program,
                 command.c_str(), CommandNames(help).c_str(), program);
    std::exit(2);
  }
  // Refused rather than ignored: most likely a flag whose "--" or "=" went
  // missing.
  if (positional.size() > 2) {
    std::fprintf(stderr,
                 "%s %s: unexpected argument '%s' (one command, then flags: is a '--' or '=' "
                 "missing?); see %s %s --help\n",
                 program, command.c_str(), positional[2], program, command.c_str());
    std::exit(2);
  }
  return command;
}

}  // namespace riskplan::cmdline
