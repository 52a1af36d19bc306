// `cadinterp explore`: validates an asset with the native runtime, then serves it with the
// explorer page and the WebAssembly runtime over HTTP (explore_server.h). CMake compiles this
// file only when cpp-httplib is found; cli_explore_unavailable.cpp stands in otherwise.
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "explore_server.h"
#include "format/asset_reader.h"
#include "json_writer.h"

namespace cadinterp::cli {
namespace {

bool is_regular_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return f.good() && f.peek() != std::ifstream::traits_type::eof();
}

std::vector<std::uint8_t> read_whole_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) throw RuntimeFailure(describe(CADINTERP_E_IO, "cannot open " + path));
  const std::streamoff size = f.tellg();
  if (size < 0) throw RuntimeFailure(describe(CADINTERP_E_IO, "cannot read " + path));
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  f.seekg(0);
  if (!f.read(reinterpret_cast<char*>(bytes.data()), size))
    throw RuntimeFailure(describe(CADINTERP_E_IO, "cannot read " + path));
  return bytes;
}

struct ExploreListening {
  std::string asset;
};

void print_explore_url(const std::string& url, void* user) {
  const auto* l = static_cast<const ExploreListening*>(user);
  // The URL line is what scripts wait for (scripts/test-explorer.sh parses it): flush at once.
  std::printf("serving %s at %s  (Ctrl-C to stop)\n", l->asset.c_str(), url.c_str());
  std::fflush(stdout);
}

/// Counts the feasible elements and, unless `quick`, evaluates each one; a failure names the
/// element.
void verify_elements(const cadinterp_asset* asset, const cadinterp::core::CompiledBasis& basis,
                     const std::string& path, bool quick, int* feasible, int* verified) {
  const auto uK = static_cast<std::size_t>(basis.dim());
  // Every element's blobs are decoded (and checksummed) by one evaluation with all fields, so
  // a damaged blob is found here instead of as an error in the browser mid-drag.
  const std::vector<int> all_fields = select_fields(asset, "all");
  WorkspacePtr ws = make_workspace(asset);
  std::vector<double> lo(uK), hi(uK), x(uK);
  cadinterp_mesh mesh{};
  for (int e = 0; e < basis.element_count(); ++e) {
    if (!basis.element_feasible(e)) continue;
    ++*feasible;
    if (quick) continue;
    basis.element_box(e, lo.data(), hi.data());
    for (std::size_t d = 0; d < uK; ++d) x[d] = 0.5 * (lo[d] + hi[d]);
    const cadinterp_status es = cadinterp_eval(ws.get(), x.data(), all_fields.data(),
                                               static_cast<int>(all_fields.size()), &mesh);
    if (es != CADINTERP_OK)
      throw RuntimeFailure("invalid asset " + path + ": element " + std::to_string(e) + ": " +
                           describe(es, cadinterp_workspace_error(ws.get())));
    ++*verified;
  }
}

/// The explorer page and the WebAssembly runtime must exist before the server starts.
void require_page(const std::string& web_root, const std::string& wasm_dir) {
  if (!is_regular_file(web_root + "/index.html"))
    throw RuntimeFailure(describe(
        CADINTERP_E_IO, "the explorer page is not built: " + web_root +
                            "/index.html is missing (build the target cadinterp_explorer_page "
                            "after `npm ci` in examples/explorer, or pass --web-root)"));
  for (const char* f : {"cadinterp.mjs", "cadinterp_wasm.mjs", "cadinterp_wasm.wasm"})
    if (!is_regular_file(wasm_dir + "/" + f))
      throw RuntimeFailure(
          describe(CADINTERP_E_IO, "the WebAssembly runtime is missing: " + wasm_dir + "/" + f +
                                       " not found (build it with scripts/build-wasm.sh, or pass "
                                       "--wasm-dir)"));
}

}  // namespace

int cmd_explore(const std::vector<std::string>& args) {
  std::string path, bind = "127.0.0.1";
  std::string web_root = CADINTERP_EXPLORER_WEB_ROOT, wasm_dir = CADINTERP_EXPLORER_WASM_DIR;
  int port = 8080;
  bool quick = false;
  ArgParser p(
      "cadinterp explore", "ASSET [--port N] [--bind ADDR] [--web-root DIR] [--wasm-dir DIR]",
      "Serves the interactive explorer for ASSET: a web page with one slider per parameter that\n"
      "evaluates the asset in the browser with the WebAssembly runtime (shape, fields, mass\n"
      "properties, boundary conditions, infeasible ranges, error estimate). The asset is first\n"
      "validated with the native runtime: its index, and one evaluation with every field in\n"
      "each feasible element. Runs until Ctrl-C.");
  p.positional("ASSET", "the asset file (.cadi)", &path);
  p.option("port", 'p', "N", "TCP port; 0 picks any free port", &port, 0, 65535);
  p.option("bind", 0, "ADDR", "address to listen on (0.0.0.0: every interface)", &bind);
  p.option("web-root", 0, "DIR", "the built explorer page", &web_root);
  p.option("wasm-dir", 0, "DIR",
           "the WebAssembly runtime (cadinterp.mjs, cadinterp_wasm.mjs,\ncadinterp_wasm.wasm; "
           "scripts/build-wasm.sh writes them)",
           &wasm_dir);
  p.flag("quick", 0, "validate the header and index only, not each element's meshes", &quick);
  p.epilog(
      "examples:\n"
      "  cadinterp explore bracket.cadi                 # then open http://127.0.0.1:8080/\n"
      "  cadinterp explore bracket.cadi --port 0        # any free port (the URL is printed)");
  if (!p.parse(args)) return kExitOk;

  // The bytes served are the bytes validated here: read once, checked from memory.
  const std::vector<std::uint8_t> bytes = read_whole_file(path);
  cadinterp_asset* raw = nullptr;
  const cadinterp_status s = cadinterp_open_memory(bytes.data(), bytes.size(), 0, &raw);
  if (s != CADINTERP_OK)
    throw RuntimeFailure("invalid asset " + path + ": " + describe(s, cadinterp_open_error()));
  AssetPtr asset(raw);
  std::unique_ptr<format::AssetReader> reader;
  try {
    reader = format::AssetReader::open_memory(bytes.data(), bytes.size(), false);
  } catch (const format::FormatError& e) {
    throw RuntimeFailure("invalid asset " + path + ": " +
                         describe(static_cast<int>(e.status), e.what()));
  }
  const cadinterp::core::CompiledBasis& basis = reader->basis();
  const auto uK = static_cast<std::size_t>(basis.dim());
  int feasible = 0, verified = 0;
  const auto t0 = Clock::now();
  verify_elements(asset.get(), basis, path, quick, &feasible, &verified);
  const double check_seconds = seconds_since(t0);
  if (feasible == 0)
    throw RuntimeFailure(describe(CADINTERP_E_INFEASIBLE,
                                  path + " has no feasible element: there is nothing to explore"));

  require_page(web_root, wasm_dir);

  std::string name = path;
  if (const std::size_t slash = name.find_last_of('/'); slash != std::string::npos)
    name = name.substr(slash + 1);
  std::string summary;
  {
    JsonWriter w(summary);
    w.begin_object().field("name", name).field("bytes", static_cast<std::uint64_t>(bytes.size()));
    w.field("runtime", std::string(cadinterp_version()));
    w.field("parameters", static_cast<int>(uK)).field("elements", basis.element_count());
    w.field("feasible_elements", feasible).field("verified_elements", verified);
    w.field("fields", cadinterp_field_count(asset.get())).end_object();
  }
  std::printf("asset %s: %zu parameters, %d elements (%d feasible), %d fields; %s\n", path.c_str(),
              uK, basis.element_count(), feasible, cadinterp_field_count(asset.get()),
              quick ? "index verified"
                    : fmt("every feasible element evaluated natively in %s",
                          human_seconds(check_seconds).c_str())
                          .c_str());

  ExploreServerOptions o;
  o.bind = bind;
  o.port = port;
  o.web_root = web_root;
  o.wasm_dir = wasm_dir;
  o.asset_name = name;
  o.asset_bytes = &bytes;
  o.asset_summary_json = summary;
  o.asset = asset.get();
  ExploreListening listening{path};
  try {
    run_explore_server(o, print_explore_url, &listening);
  } catch (const std::runtime_error& e) {
    throw RuntimeFailure(describe(CADINTERP_E_IO, e.what()));
  }
  std::printf("stopped\n");
  return kExitOk;
}

}  // namespace cadinterp::cli
