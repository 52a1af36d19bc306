// The builder's figures for the closing notes (paper §7, Tables 1-2, ours) on the analytic
// models: samples and time per model, accuracy at random points, adaptive against uniform
// sample counts at equal error, and the speedup from 1 to 2 threads. With --calls, only the
// host's cost (§4.2): host calls against kept samples and the measured error, per model. With
// --estimates, the calibration of cadinterp_error_estimates per model and degree: on two
// disjoint sets of random points (seeds 7 and 11), per quantity, the fraction of points where
// the estimate bounds the error measured against the host and the median estimate / error.
//   cadinterp-builder-figures [--points N] [--host-options OPTS] [--calls | --estimates
//                             [--model NAME]]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp_builder.h"

namespace {

using namespace cadinterp;

struct Run {
  cadinterp_build_report report{};
  double seconds = 0;
};

Run build(const cadinterp_host* host, const cadinterp_build_options& o, const std::string& path) {
  const auto t0 = std::chrono::steady_clock::now();
  const builder::BuildOutcome b = builder::build_asset(*host, o, path);
  if (b.status != CADINTERP_OK) {
    std::fprintf(stderr, "build: %s\n", b.error.c_str());
    std::exit(1);
  }
  Run r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.report = b.report;
  return r;
}

// The analytic host `model`, or null after printing why.
const cadinterp_host* analytic_host(const char* model, const std::string& options) {
  const char* err = nullptr;
  const cadinterp_host* host = cadinterp_host_entry(model, options.c_str(), &err);
  if (!host) std::fprintf(stderr, "%s: %s\n", model, err ? err : "?");
  return host;
}

// The builder's defaults with the figures' budget of 400 samples.
cadinterp_build_options figure_options() {
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 400;
  return o;
}

// The analytic models of the host-call and estimate tables, with their host options.
struct Model {
  const char* name;
  std::string options;
};
std::vector<Model> table_models(const std::string& bracket_options) {
  return {{"bracket", bracket_options}, {"plate", ""}, {"foldplate", "edge=10"}};
}

// Host calls per kept sample and the error measured against the host (not the driver's own
// estimate), one build per model at the figures' defaults.
int host_calls_table(const std::string& bracket_options, int points, const std::string& path) {
  std::printf("model      samples  host calls  calls/sample  geometry max  field max  wall s\n");
  for (const Model& m : table_models(bracket_options)) {
    const char* model = m.name;
    const cadinterp_host* host = analytic_host(model, m.options);
    if (!host) return 1;
    const mesh::Host h(*host);
    cadinterp_build_options o = figure_options();
    o.threads = 1;
    const Run r = build(host, o, path);
    const builder::AccuracyReport a = builder::measure_accuracy(path, h, points, 7);
    std::printf("%-10s %7d  %10d  %12.2f  %12.2e  %9.2e  %6.2f\n", model, r.report.samples,
                r.report.host_evaluations,
                static_cast<double>(r.report.host_evaluations) / std::max(1, r.report.samples),
                a.geometry_max, a.field_max, r.seconds);
  }
  std::filesystem::remove(path);
  return 0;
}

// One calibration row per quantity: points, coverage and median ratio on each point set.
void print_estimates(const char* model, int degree, const builder::AccuracyReport& a,
                     const builder::AccuracyReport& b) {
  for (std::size_t q = 0; q < a.estimate_points.size() && q < b.estimate_points.size(); ++q) {
    const std::string name = q ? a.field_names[q - 1] : "geometry";
    std::printf("%-10s %6d  %-12s %6d  %7.1f %%  %9.2f  %9.2f  %6d  %7.1f %%  %9.2f  %9.2f\n",
                model, degree, name.c_str(), a.estimate_points[q], 100 * a.estimate_coverage[q],
                a.estimate_median_ratio[q], a.estimate_p10_ratio[q], b.estimate_points[q],
                100 * b.estimate_coverage[q], b.estimate_median_ratio[q], b.estimate_p10_ratio[q]);
  }
}

// The calibration of the per-point error estimates (cadinterp_error_estimates) against the
// host at random points, per model and degree, at the figures' defaults.
int estimates_table(const std::string& bracket_options, int points, const std::string& only,
                    const std::string& path) {
  std::printf(
      "model      degree  quantity     set A:  n  bounded  med ratio  p10 ratio  set B:  n  "
      "bounded  med ratio  p10 ratio\n");
  for (const Model& m : table_models(bracket_options)) {
    if (!only.empty() && only != m.name) continue;
    const cadinterp_host* host = analytic_host(m.name, m.options);
    if (!host) return 1;
    const mesh::Host h(*host);
    for (int degree : {1, 3}) {
      cadinterp_build_options o = figure_options();
      o.degree = degree;
      build(host, o, path);
      print_estimates(m.name, degree, builder::measure_accuracy(path, h, points, 7),
                      builder::measure_accuracy(path, h, points, 11));
    }
  }
  std::filesystem::remove(path);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int points = 200;
  bool calls = false, estimates = false;
  std::string only;  // --estimates: this model alone
  std::string options = "cells=6";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--calls"))
      calls = true;
    else if (!std::strcmp(argv[i], "--estimates"))
      estimates = true;
    else if (!std::strcmp(argv[i], "--model") && i + 1 < argc)
      only = argv[++i];
    else if (!std::strcmp(argv[i], "--points") && i + 1 < argc)
      points = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--host-options") && i + 1 < argc)
      options = argv[++i];
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const std::string path =
      (std::filesystem::temp_directory_path() / "cadinterp_builder_figures.cadi").string();
  if (calls) return host_calls_table(options, points, path);
  if (estimates) return estimates_table(options, points, only, path);
  for (const char* model : {"bracket", "plate"}) {
    const cadinterp_host* host =
        analytic_host(model, std::strcmp(model, "bracket") ? "" : options.c_str());
    if (!host) return 1;
    const mesh::Host h(*host);
    cadinterp_build_options o = figure_options();
    std::printf("== %s (%s), K=%d\n", model, h.identity().c_str(), h.dim());
    Run one, two;
    for (int threads : {1, 2}) {
      o.threads = threads;
      (threads == 1 ? one : two) = build(host, o, path);
    }
    const cadinterp_build_report& r = two.report;
    const builder::AccuracyReport a = builder::measure_accuracy(path, h, points, 7);
    std::printf(
        "adaptive (geometry tol %.0e, field tol %.0e): %d samples, %d elements (%d infeasible), "
        "%d meshes stored, %.1f KB; host %.2f ms/sample; wall 1 thread %.2f s, 2 threads %.2f s "
        "(speedup %.2f)\n",
        o.geometry_tolerance, o.field_tolerance, r.samples, r.elements, r.infeasible_elements,
        r.stored_meshes, static_cast<double>(r.asset_bytes) / 1e3,
        1e3 * r.host_seconds / std::max(1, r.host_evaluations), one.seconds, two.seconds,
        one.seconds / two.seconds);
    std::printf(
        "  accuracy at %d random points (%d infeasible): geometry max %.2e p99 %.2e; "
        "field max %.2e p99 %.2e\n",
        a.points, a.infeasible, a.geometry_max, a.geometry_p99, a.field_max, a.field_p99);
    // Uniform: every element split to the same depth (a tolerance nothing meets, and the depth
    // limit), deeper until the measured error is at most the adaptive one.
    for (int depth = 1; depth <= 6; ++depth) {
      double predicted = 1;  // (2^depth + 1)^K samples of the uniform linear tree
      for (int d = 0; d < h.dim(); ++d) predicted *= (1 << depth) + 1;
      if (predicted > 3000) {
        std::printf("  uniform depth %d: %.0f samples, not built\n", depth, predicted);
        break;
      }
      cadinterp_build_options u = o;
      u.geometry_tolerance = u.field_tolerance = 1e-12;
      u.max_depth = depth;
      u.max_samples = 100000;
      const Run ur = build(host, u, path);
      const builder::AccuracyReport ua = builder::measure_accuracy(path, h, points, 7);
      std::printf("  uniform depth %d: %d samples; geometry max %.2e p99 %.2e; field max %.2e\n",
                  depth, ur.report.samples, ua.geometry_max, ua.geometry_p99, ua.field_max);
      if (ua.geometry_max <= a.geometry_max && ua.field_max <= a.field_max) break;
    }
  }
  std::filesystem::remove(path);
  return 0;
}
