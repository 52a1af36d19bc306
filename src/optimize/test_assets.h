// Assets of the optimizer tests (test_host.h), built once per test process into temporary files
// and opened with the runtime.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "cadinterp/cadinterp.h"
#include "optimize/test_host.h"

namespace cadinterp::optimize::test {

struct OpenedAsset {
  std::unique_ptr<BoxHost> host;
  std::string path;
  cadinterp_asset* asset = nullptr;
  cadinterp_build_report report{};
  ~OpenedAsset() {
    cadinterp_close(asset);
    std::filesystem::remove(path);
  }
};

// The asset of BoxHost(K, target, fail) at `degree`, or null with `error` set.
inline const OpenedAsset* box_asset(int K, int degree, std::array<double, 5> target, bool fail,
                                    std::string* error) {
  static std::map<std::string, std::unique_ptr<OpenedAsset>> cache;
  auto host = std::make_unique<BoxHost>(K, target, fail);
  const std::string key = host->identity + " degree " + std::to_string(degree);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second.get();
  auto o = std::make_unique<OpenedAsset>();
  o->path = (std::filesystem::temp_directory_path() /
             ("cadinterp_optimize_test_" + std::to_string(::getpid()) + "_" +
              std::to_string(cache.size()) + ".cadi"))
                .string();
  // Small sample budgets keep the suite fast; the cubic basis needs more per dimension.
  *error = host->build(o->path, degree, K <= 3 ? 150 * K : 250 * K, &o->report);
  std::fprintf(stderr, "[asset] %s: %d samples, %d elements, max error %.3g of target%s\n",
               key.c_str(), o->report.samples, o->report.elements, o->report.max_error,
               o->report.budget_exhausted ? " (sample budget exhausted)" : "");
  if (!error->empty()) return nullptr;
  if (cadinterp_open(o->path.c_str(), &o->asset) != CADINTERP_OK) {
    *error = cadinterp_open_error();
    return nullptr;
  }
  o->host = std::move(host);
  return (cache[key] = std::move(o)).get();
}

}  // namespace cadinterp::optimize::test
