// The HTTP side of `cadinterp explore`: serves the explorer page, the WebAssembly runtime and the
// asset's bytes to a browser, which does all the exploration itself (the page runs the asset
// through the wasm runtime). The one thing the server computes is an optimization on request
// (the page's Optimize panel: explore_optimize.h), which needs Ipopt.
#pragma once

#include <cstdint>

#include <string>
#include <vector>
#include "cadinterp/cadinterp.h"

namespace cadinterp::cli {

struct ExploreServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8080;         ///< 0: any free port
  std::string web_root;    ///< the built page (index.html, assets/)
  std::string wasm_dir;    ///< cadinterp.mjs, cadinterp_wasm.mjs, cadinterp_wasm.wasm
  std::string asset_name;  ///< file name shown by the page
  /// The asset's bytes, served at /asset.cadi exactly as validated (not re-read from disk, so
  /// an asset rewritten while the server runs cannot reach the page unvalidated).
  const std::vector<std::uint8_t>* asset_bytes = nullptr;
  std::string asset_summary_json;  ///< /asset.json: what the native runtime reported
  /// The same asset opened by the native runtime, for /api/optimize (explore_optimize.h); it
  /// must outlive the server.
  const cadinterp_asset* asset = nullptr;
};

/// MIME type by file name extension (lower case), "application/octet-stream" if unknown.
/// application/wasm matters: WebAssembly.instantiateStreaming refuses any other type.
const char* mime_type_for(const std::string& path);

/// Binds, calls `on_listening(url)` once the socket accepts connections, then serves until
/// SIGINT or SIGTERM. Returns 0 after a clean stop; throws std::runtime_error when the address
/// cannot be bound (the message names it).
int run_explore_server(const ExploreServerOptions& options,
                       void (*on_listening)(const std::string& url, void* user), void* user);

}  // namespace cadinterp::cli
