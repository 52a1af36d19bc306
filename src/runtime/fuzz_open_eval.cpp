// libFuzzer target: arbitrary bytes through open + eval + grad + vjp + properties of the C ABI.
// Any crash, sanitizer report or leak is a bug; every input must end in a status.
// Build and run: scripts/fuzz.sh [seconds] (seeds: conformance/cases/*/*/asset.cadi).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "fuzz_checksums.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> bytes(data, data + size);
  cadinterp_fuzz::fix_checksums(bytes);
  cadinterp_asset* asset = nullptr;
  if (cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset) != CADINTERP_OK) return 0;
  cadinterp_workspace* ws = nullptr;
  if (cadinterp_workspace_create(asset, &ws) == CADINTERP_OK) {
    const int K = cadinterp_parameter_count(asset);
    std::vector<double> x(static_cast<std::size_t>(K));
    const int fields[1] = {0};
    const int nf = cadinterp_field_count(asset) > 0 ? 1 : 0;
    for (double u : {0.0, 0.37, 0.5, 1.0}) {
      for (int d = 0; d < K; ++d) {
        cadinterp_parameter_info p;
        cadinterp_parameter(asset, d, &p);
        x[static_cast<std::size_t>(d)] = p.lower + u * (p.upper - p.lower);
      }
      cadinterp_mesh m;
      if (cadinterp_eval(ws, x.data(), fields, nf, &m) != CADINTERP_OK) continue;
      cadinterp_mesh_grad g;
      cadinterp_grad(ws, x.data(), fields, nf, &g);
      std::vector<float> adj(static_cast<std::size_t>(m.vertex_count) * 3, 1.0f);
      std::vector<double> out(static_cast<std::size_t>(K));
      cadinterp_vjp(ws, x.data(), adj.data(), nullptr, nullptr, 0, out.data());
      const double dir[3] = {0, 0, 1};
      cadinterp_properties props;
      cadinterp_eval_properties(ws, x.data(), 1.0, dir, &props, nullptr);
    }
    cadinterp_workspace_destroy(ws);
  }
  cadinterp_close(asset);
  return 0;
}
