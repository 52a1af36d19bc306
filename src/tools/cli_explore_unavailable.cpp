// `cadinterp explore` in a build without the explorer (CADINTERP_WITH_EXPLORER=OFF or
// cpp-httplib missing): its help, and an error for anything else. CMake compiles this file
// instead of cli_explore.cpp.
#include <string>
#include <vector>

#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"

namespace cadinterp::cli {

int cmd_explore(const std::vector<std::string>& args) {
  ArgParser p("cadinterp explore", "ASSET [--port N] [--bind ADDR] [--web-root DIR]",
              "Serves the interactive web explorer for an asset. This cadinterp was built without\n"
              "it (CADINTERP_WITH_EXPLORER=OFF or cpp-httplib missing).");
  return unavailable_command(
      p, args, "this cadinterp was built without the explorer (CADINTERP_WITH_EXPLORER)");
}

}  // namespace cadinterp::cli
