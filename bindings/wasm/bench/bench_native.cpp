// Native half of scripts/bench-wasm.sh.
//   bench_native write ASSET         writes the benchmark asset: runtime_bench's fixture (the
//                                    synthetic box at 80 x 40 x 30 cells, 103,361 vertices, K = 3,
//                                    linear, 8 elements of 8 samples, default lossless codec)
//   bench_native time ASSET [N]      times the C ABI on it and prints one JSON line, the same
//                                    measurements as bench.mjs makes on the WebAssembly build
// Each timing is the median of N calls (default 200) after a warm-up call, cycling through the
// points of kPoints; "first_eval" is open + the first eval (which decodes the element), median
// of 5.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "format/synthetic_asset.h"

namespace {

// Eight points in the element holding runtime_bench's kX = (0.3, 0.6, 0.2) (the octant
// [0, .5] x [.5, 1] x [0, .5] of the once-refined box; checked by locate): every timed call
// evaluates a cached element at a new x. Cycling through all 8 elements instead would time
// decoding as soon as fields are read (8 elements with fields exceed the 256 MiB cache).
const double kPoints[8][3] = {{0.3, 0.6, 0.2},    {0.25, 0.65, 0.15}, {0.35, 0.55, 0.25},
                              {0.2, 0.7, 0.3},    {0.4, 0.6, 0.1},    {0.3, 0.7, 0.25},
                              {0.22, 0.58, 0.18}, {0.38, 0.66, 0.28}};

void check(cadinterp_status s, cadinterp_workspace* ws, const char* what) {
  if (s == CADINTERP_OK) return;
  std::fprintf(stderr, "bench_native: %s: %s (%s)\n", what, cadinterp_status_string(s),
               ws ? cadinterp_workspace_error(ws) : cadinterp_open_error());
  std::exit(1);
}

template <class F>
double median_ms(int n, F&& call) {
  std::vector<double> t;
  call(0);
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    call(i);
    t.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::nth_element(t.begin(), t.begin() + n / 2, t.end());
  return t[static_cast<std::size_t>(n / 2)];
}

int write(const char* path) {
  const auto a =
      cadinterp::format::make_synthetic_asset(cadinterp::format::benchmark_fixture_spec());
  cadinterp::format::write_asset_file(a.content, {}, path);
  return 0;
}

int time(const char* path, int n) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
  if (bytes.empty()) {
    std::fprintf(stderr, "bench_native: cannot read %s\n", path);
    return 1;
  }
  // Opened from memory, as the WebAssembly build does.
  cadinterp_asset* asset = nullptr;
  cadinterp_workspace* ws = nullptr;
  std::vector<double> first;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    check(cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset), nullptr, "open");
    check(cadinterp_workspace_create(asset, &ws), nullptr, "workspace");
    cadinterp_mesh m;
    check(cadinterp_eval(ws, kPoints[0], nullptr, 0, &m), ws, "eval");
    first.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cadinterp_workspace_destroy(ws);
    cadinterp_close(asset);
  }
  std::sort(first.begin(), first.end());
  check(cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset), nullptr, "open");
  check(cadinterp_workspace_create(asset, &ws), nullptr, "workspace");
  cadinterp_mesh m{};
  int element = -1;
  for (const auto& x : kPoints) {
    check(cadinterp_eval(ws, x, nullptr, 0, &m), ws, "eval");
    if (element >= 0 && m.element != element) {
      std::fprintf(stderr, "bench_native: the points are not in one element\n");
      return 1;
    }
    element = m.element;
  }
  const std::uint32_t nv = m.vertex_count;
  int fi = 0;
  check(cadinterp_find_field(asset, "temperature", &fi), nullptr, "find_field");
  const double eval_ms = median_ms(
      n, [&](int i) { check(cadinterp_eval(ws, kPoints[i % 8], nullptr, 0, &m), ws, "eval"); });
  const double eval_field_ms = median_ms(
      n, [&](int i) { check(cadinterp_eval(ws, kPoints[i % 8], &fi, 1, &m), ws, "eval"); });
  cadinterp_mesh_grad g;
  const double grad_ms = median_ms(
      n, [&](int i) { check(cadinterp_grad(ws, kPoints[i % 8], nullptr, 0, &g), ws, "grad"); });
  std::vector<float> adj(3 * std::size_t(nv), 1.0f);
  double dx[3];
  const double vjp_ms = median_ms(n, [&](int i) {
    check(cadinterp_vjp(ws, kPoints[i % 8], adj.data(), nullptr, nullptr, 0, dx), ws, "vjp");
  });
  const double dir[3] = {0, 0, 1};
  cadinterp_properties p;
  const double props_ms = median_ms(n, [&](int i) {
    check(cadinterp_eval_properties(ws, kPoints[i % 8], 1.0, dir, &p, nullptr), ws, "properties");
  });
  std::printf(
      "{\"vertices\": %u, \"eval_ms\": %.4f, \"eval_field_ms\": %.4f, \"grad_ms\": %.4f, "
      "\"vjp_ms\": %.4f, \"properties_ms\": %.4f, \"first_eval_ms\": %.4f}\n",
      nv, eval_ms, eval_field_ms, grad_ms, vjp_ms, props_ms, first[2]);
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 3 && std::strcmp(argv[1], "write") == 0) return write(argv[2]);
  if (argc >= 3 && std::strcmp(argv[1], "time") == 0)
    return time(argv[2], argc >= 4 ? std::max(1, std::atoi(argv[3])) : 200);
  std::fprintf(stderr, "usage: bench_native write ASSET | time ASSET [N]\n");
  return 2;
}
