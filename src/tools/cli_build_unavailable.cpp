// `cadinterp build` in a build without libcadinterp_builder: its help, and an error for anything
// else. CMake compiles this file instead of cli_build.cpp.
#include <string>
#include <vector>

#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"

namespace cadinterp::cli {

const char* builder_availability() { return "no (built without libcadinterp_builder)"; }

// Built-in hosts are linked through the builder's host interface; without it there are none.
std::string builtin_hosts() { return std::string(); }

int cmd_build(const std::vector<std::string>& args) {
  ArgParser p("cadinterp build", "--host PATH|NAME -o OUT.cadi [options]",
              "Precomputes a parametric model into an asset. This cadinterp was built without\n"
              "the builder library (libcadinterp_builder), so building is not available.");
  return unavailable_command(p, args, "this cadinterp was built without libcadinterp_builder");
}

}  // namespace cadinterp::cli
