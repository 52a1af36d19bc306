// The `cadinterp` commands, one file each (cli_<command>.cpp); cli_main.cpp dispatches to them.
// A command whose library is absent from the build comes from cli_<command>_unavailable.cpp,
// which CMake picks instead. Each takes the arguments after its name and returns the exit code;
// errors are thrown (UsageError: exit 2, RuntimeFailure and the rest: exit 1).
#pragma once

#include <string>
#include <vector>

namespace cadinterp::cli {

int cmd_build(const std::vector<std::string>& args);
int cmd_inspect(const std::vector<std::string>& args);
int cmd_eval(const std::vector<std::string>& args);
int cmd_bench(const std::vector<std::string>& args);
int cmd_explore(const std::vector<std::string>& args);
int cmd_optimize(const std::vector<std::string>& args);

/// For `cadinterp --version`, from whichever file provides cmd_build: "yes", or "no (why)".
const char* builder_availability();
/// The hosts linked into the tool, selectable by name in `build --host` (comma list, "" for
/// none).
std::string builtin_hosts();

}  // namespace cadinterp::cli
