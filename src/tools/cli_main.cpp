// cadinterp: the command-line tool.
//
//   cadinterp build    --host PATH|NAME -o OUT.cadi [options]   precompute an asset
//   cadinterp inspect  ASSET [--json]                             what an asset holds
//   cadinterp eval     ASSET X1 X2 ... [options]                  shape, metrics, exports at x
//   cadinterp bench    ASSET [--iterations N]                     open/eval/grad/vjp timings
//   cadinterp explore  ASSET [--port N] [--bind ADDR]             the web explorer for ASSET
//   cadinterp optimize ASSET --minimize EXPR [--subject-to C ...]  Ipopt on the interpolant
//
// Exit codes: 0 success, 1 a runtime or build error (the message names the cadinterp_status),
// 2 a malformed command line. Evaluation goes through the public C ABI only, so the tool behaves
// as an application would; `inspect` (sizes, codecs, tree statistics) and `bench` (element boxes,
// to evaluate each element once cold) read the index with the format library, because those are
// not, and should not be, part of the ABI.
//
// This file owns the dispatch, the top-level help and --version; each command is in its own
// file (cli_commands.h).
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"

namespace cadinterp::cli {
namespace {

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const std::vector<std::string>& args);
};

const Command kCommands[] = {
    {"build", "precompute a parametric model into an asset (.cadi) through a host", cmd_build},
    {"inspect", "show what an asset holds: parameters, tree, sizes, codecs, provenance",
     cmd_inspect},
    {"eval", "evaluate an asset at parameters x: metrics, derivatives, mesh export", cmd_eval},
    {"bench", "time opening and evaluating an asset", cmd_bench},
    {"explore", "serve the interactive web explorer for an asset (sliders, live mesh, fields)",
     cmd_explore},
    {"optimize", "minimize a quantity of the interpolated shape with Ipopt (exact gradients)",
     cmd_optimize},
};

std::string top_help() {
  std::string s =
      "usage: cadinterp COMMAND [ARGS...]\n"
      "       cadinterp COMMAND --help\n\n"
      "Precompute parametric CAD models into interpolating assets and evaluate them.\n\n"
      "commands:\n";
  for (const Command& c : kCommands) s += fmt("  %-10s%s\n", c.name, c.summary);
  s += "\noptions:\n"
       "  --version   print the library, format and builder versions\n"
       "  -h, --help  show this help\n\n"
       "Exit status: 0 success, 1 runtime or build error, 2 usage error.\n";
  return s;
}

void print_version() {
  int major = 0, minor = 0;
  cadinterp_format_version(&major, &minor);
  std::printf("cadinterp %s (asset format %d.%d)\n", cadinterp_version(), major, minor);
  std::printf("builder: %s\n", builder_availability());
  const std::string hosts = builtin_hosts();
  std::printf("built-in hosts: %s\n", hosts.empty() ? "none" : hosts.c_str());
}

int run(const std::vector<std::string>& args) {
  if (args.empty()) {
    std::fputs(top_help().c_str(), stderr);
    return kExitUsage;
  }
  const std::string& cmd = args[0];
  if (cmd == "-h" || cmd == "--help") {
    std::fputs(top_help().c_str(), stdout);
    return kExitOk;
  }
  if (cmd == "--version" || cmd == "version") {
    print_version();
    return kExitOk;
  }
  std::vector<std::string> rest(args.begin() + 1, args.end());
  const Command* c = nullptr;
  std::string name = cmd;
  if (cmd == "help") {
    if (rest.empty()) {
      std::fputs(top_help().c_str(), stdout);
      return kExitOk;
    }
    name = rest[0];
    rest = {"--help"};
  }
  for (const Command& k : kCommands)
    if (name == k.name) c = &k;
  if (!c) {
    std::fprintf(stderr,
                 "cadinterp: unknown command '%s' (commands: build, inspect, eval, bench, explore, "
                 "optimize; "
                 "see 'cadinterp --help')\n",
                 name.c_str());
    return kExitUsage;
  }
  const std::string prog = std::string("cadinterp ") + c->name;
  try {
    return c->run(rest);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n(see '%s --help')\n", prog.c_str(), e.what(), prog.c_str());
    return kExitUsage;
  } catch (const RuntimeFailure& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(), e.what());
    return kExitError;
  } catch (const format::FormatError& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(),
                 describe(static_cast<int>(e.status), e.what()).c_str());
    return kExitError;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(),
                 describe(CADINTERP_E_OUT_OF_MEMORY, "").c_str());
    return kExitError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog.c_str(), e.what());
    return kExitError;
  }
}

}  // namespace
}  // namespace cadinterp::cli

int main(int argc, char** argv) {
  return cadinterp::cli::run(std::vector<std::string>(argv + 1, argv + argc));
}
