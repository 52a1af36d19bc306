// `cadinterp optimize` in a build without libcadinterp_optimize (CADINTERP_WITH_OPTIMIZE=OFF or
// Ipopt not found by pkg-config): its help, and an error for anything else. CMake compiles this
// file instead of cli_optimize.cpp.
#include <string>
#include <vector>

#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"

namespace cadinterp::cli {

int cmd_optimize(const std::vector<std::string>& args) {
  ArgParser p("cadinterp optimize", "ASSET --minimize EXPR [--subject-to 'EXPR <= V' ...]",
              "Minimizes a quantity of the interpolated shape with Ipopt. This cadinterp was\n"
              "built without it (CADINTERP_WITH_OPTIMIZE=OFF or Ipopt not found: Debian\n"
              "coinor-libipopt-dev).");
  return unavailable_command(
      p, args, "this cadinterp was built without optimization (CADINTERP_WITH_OPTIMIZE)");
}

}  // namespace cadinterp::cli
