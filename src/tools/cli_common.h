// What the `cadinterp` commands share: exit codes, the error message format, number formatting,
// owning handles for the C ABI and the index reader, and field selection. Each command's own
// helpers live in its file (cli_<command>.cpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cli_args.h"
#include "format/asset_reader.h"

namespace cadinterp::cli {

constexpr int kExitOk = 0, kExitError = 1, kExitUsage = 2;

/// A failure reported with exit code 1; what() is the whole message.
struct RuntimeFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// "CADINTERP_E_X (fixed text): detail" — the enum name is what users search for in the header.
std::string describe(int status, const std::string& detail);

std::string fmt(const char* f, ...) __attribute__((format(printf, 1, 2)));
std::string human_bytes(std::uint64_t b);
std::string human_seconds(double s);

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0);

// ---- C ABI handles ---------------------------------------------------------------------------

struct AssetCloser {
  void operator()(cadinterp_asset* a) const { cadinterp_close(a); }
};
struct WorkspaceDestroyer {
  void operator()(cadinterp_workspace* w) const { cadinterp_workspace_destroy(w); }
};
using AssetPtr = std::unique_ptr<cadinterp_asset, AssetCloser>;
using WorkspacePtr = std::unique_ptr<cadinterp_workspace, WorkspaceDestroyer>;

/// Throws RuntimeFailure naming `path` and the runtime's status.
AssetPtr open_asset(const std::string& path);
WorkspacePtr make_workspace(const cadinterp_asset* a);
/// Throws RuntimeFailure "what: STATUS (text): the workspace's message" unless `s` is OK.
void check_ws(cadinterp_status s, const cadinterp_workspace* ws, const std::string& what);

/// The index of the asset at `path`, verified; a format error becomes a RuntimeFailure. For
/// what the C ABI deliberately does not expose (sizes, codecs, element boxes).
std::unique_ptr<format::AssetReader> open_index(const std::string& path);

/// Field indices for --fields (a comma list of names, "all", or "" for none); an unknown name
/// is a UsageError listing the asset's fields.
std::vector<int> select_fields(const cadinterp_asset* a, const std::string& spec);

/// A command this build lacks: prints `p`'s help for --help/-h (exit 0), otherwise throws
/// RuntimeFailure(`failure`). Nothing else on the command line is checked.
int unavailable_command(const ArgParser& p, const std::vector<std::string>& args,
                        const std::string& failure);

}  // namespace cadinterp::cli
