// The builder's figures for the closing notes (paper §7, Tables 1-2, ours) on the analytic
// models: samples and time per model, accuracy at random points, adaptive against uniform
// sample counts at equal error, and the speedup from 1 to 2 threads. With --calls, only the
// host's cost (§4.2): host calls against kept samples and the measured error, per model. With
// --infeasible, the feasible space kept: on hosts failing in 16 % of their box (fail_region=2),
// the part of the box the runtime refuses against the part where the host fails, at each of
// --budgets (default 120,600). With
// --estimates, the calibration of cadinterp_error_estimates per model and degree: on two
// disjoint sets of random points (seeds 7 and 11), per quantity, the fraction of points where
// the estimate bounds the error measured against the host and the median estimate / error;
// with --calibration-points N, of assets whose builder calibrated the estimates on N points of
// its own (cadinterp_build_options::calibration_points).
//   cadinterp-builder-figures [--points N] [--host-options OPTS]
//                             [--calls | --infeasible [--budgets N,...] |
//                              --estimates [--calibration-points N]]
//                             [--model NAME]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp.h"
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
  if (!b.calibration.empty()) {
    std::fprintf(stderr, "calibrated on %d points, factors", b.stages.calibrated_points);
    for (double c : b.calibration) std::fprintf(stderr, " %.3g", c);
    std::fprintf(stderr, ", floors added");
    for (double f : b.calibration_floors) std::fprintf(stderr, " %.3g", f);
    std::fprintf(stderr, " (geometry, then each field)\n");
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
// estimate), one build per model and face-centre test (all, lazy: the build option
// lazy_face_centres) at the figures' defaults.
// `only`: one model's row (empty: all).
int host_calls_table(const std::string& bracket_options, int points, const std::string& only,
                     const std::string& path) {
  std::printf(
      "model      faces  samples  host calls  calls/sample  geometry max  field max  wall s\n");
  for (const Model& m : table_models(bracket_options)) {
    if (!only.empty() && only != m.name) continue;
    const char* model = m.name;
    const cadinterp_host* host = analytic_host(model, m.options);
    if (!host) return 1;
    const mesh::Host h(*host);
    for (int lazy : {0, 1}) {
      cadinterp_build_options o = figure_options();
      o.threads = 1;
      o.lazy_face_centres = lazy;
      const Run r = build(host, o, path);
      const builder::AccuracyReport a = builder::measure_accuracy(path, h, points, 7);
      std::printf("%-10s %-5s  %7d  %10d  %12.2f  %12.2e  %9.2e  %6.2f\n", model,
                  lazy ? "lazy" : "all", r.report.samples, r.report.host_evaluations,
                  static_cast<double>(r.report.host_evaluations) / std::max(1, r.report.samples),
                  a.geometry_max, a.field_max, r.seconds);
    }
  }
  std::filesystem::remove(path);
  return 0;
}

// Per point of `xs` (K values each): whether the asset at `path` refuses it (cadinterp_locate's
// infeasible element).
std::vector<char> refused_points(const std::string& path, const std::vector<double>& xs, int K) {
  cadinterp_asset* asset = nullptr;
  if (cadinterp_open(path.c_str(), &asset) != CADINTERP_OK) {
    std::fprintf(stderr, "open %s: %s\n", path.c_str(), cadinterp_open_error());
    std::exit(1);
  }
  std::vector<char> refused(xs.size() / static_cast<std::size_t>(K));
  for (std::size_t i = 0; i < refused.size(); ++i) {
    int element = -1, feasible = 0;
    if (cadinterp_locate(asset, &xs[i * static_cast<std::size_t>(K)], &element, &feasible) !=
        CADINTERP_OK) {
      std::fprintf(stderr, "locate failed\n");
      std::exit(1);
    }
    refused[i] = feasible ? 0 : 1;
  }
  cadinterp_close(asset);
  return refused;
}

// "120,600" as {120, 600}; empty when an entry is not a whole number >= 1.
std::vector<int> parse_budgets(const char* text) {
  std::vector<int> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end || v < 1 || v > 1000000) return {};
    out.push_back(static_cast<int>(v));
  }
  return out;
}

// The feasible space kept: per model, degree, budget and bound on failed points
// (infeasible_call_fraction; "none" = no bound), the fraction of `points` random points the
// runtime refuses, the fraction where the host fails, the refused points the host regenerates
// ("lost") and the points the runtime interpolates although the host fails there ("across"),
// with the host evaluations of the build and those that failed.
int infeasible_table(int points, const std::vector<int>& budgets, const std::string& only,
                     const std::string& path) {
  std::printf(
      "model    deg  budget  bound  samples  refused %%  host fails %%  excess %%  lost %%  "
      "across %%  host evals  failed evals  max error  wall s\n");
  for (const char* model : {"plate", "bracket"}) {
    if (!only.empty() && only != model) continue;
    const std::string opts =
        std::strcmp(model, "bracket") ? "fail_region=2" : "cells=2,fail_region=2";
    const cadinterp_host* host = analytic_host(model, opts);
    if (!host) return 1;
    const mesh::Host h(*host);
    const int K = h.dim();
    std::mt19937 rng(11);
    std::vector<double> xs;
    std::vector<char> fails;
    for (int i = 0; i < points; ++i) {
      for (int d = 0; d < K; ++d)
        xs.push_back(std::uniform_real_distribution<double>(
            h.lower()[static_cast<std::size_t>(d)], h.upper()[static_cast<std::size_t>(d)])(rng));
      fails.push_back(h.evaluate(&xs[xs.size() - static_cast<std::size_t>(K)]).feasible ? 0 : 1);
    }
    for (int degree : {1, 3})
      for (int budget : budgets)
        for (double bound : {0.25, -1.0}) {
          if (budget < 600 && bound < 0) continue;  // small budgets never reach the bound
          cadinterp_build_options o = figure_options();
          o.degree = degree;
          o.max_samples = budget;
          o.infeasible_call_fraction = bound;
          const Run r = build(host, o, path);
          const std::vector<char> refused = refused_points(path, xs, K);
          int n_refused = 0, n_fails = 0, lost = 0, across = 0;
          for (std::size_t i = 0; i < refused.size(); ++i) {
            n_refused += refused[i];
            n_fails += fails[i];
            lost += refused[i] && !fails[i];
            across += !refused[i] && fails[i];
          }
          const double pc = 100.0 / points;
          std::printf(
              "%-8s %3d  %6d  %5s  %7d  %9.1f  %12.1f  %8.1f  %6.1f  %8.1f  %10d  %12d  %9.2f  "
              "%6.1f\n",
              model, degree, budget, bound < 0 ? "none" : "0.25", r.report.samples, n_refused * pc,
              n_fails * pc, (n_refused - n_fails) * pc, lost * pc, across * pc,
              r.report.host_evaluations, r.report.infeasible_host_evaluations, r.report.max_error,
              r.seconds);
        }
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
                    int calibration_points, const std::string& path) {
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
      o.calibration_points = calibration_points;
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
  bool calls = false, infeasible = false, estimates = false;
  std::string options = "cells=6", only_model;
  std::vector<int> budgets{120, 600};
  int calibration_points = 0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--calls"))
      calls = true;
    else if (!std::strcmp(argv[i], "--infeasible"))
      infeasible = true;
    else if (!std::strcmp(argv[i], "--estimates"))
      estimates = true;
    else if (!std::strcmp(argv[i], "--model") && i + 1 < argc)
      only_model = argv[++i];
    else if (!std::strcmp(argv[i], "--points") && i + 1 < argc)
      points = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--host-options") && i + 1 < argc)
      options = argv[++i];
    else if (!std::strcmp(argv[i], "--budgets") && i + 1 < argc)
      budgets = parse_budgets(argv[++i]);
    else if (!std::strcmp(argv[i], "--calibration-points") && i + 1 < argc)
      calibration_points = std::atoi(argv[++i]);
  }
  if (calibration_points < 0 || calibration_points > CADINTERP_MAX_CALIBRATION_POINTS) {
    std::fprintf(stderr, "--calibration-points: 0..%d\n", CADINTERP_MAX_CALIBRATION_POINTS);
    return 2;
  }
  if (budgets.empty()) {
    std::fprintf(stderr, "--budgets: a comma-separated list of sample budgets >= 1\n");
    return 2;
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const std::string path =
      (std::filesystem::temp_directory_path() / "cadinterp_builder_figures.cadi").string();
  if (calls) return host_calls_table(options, points, only_model, path);
  if (infeasible) return infeasible_table(points, budgets, only_model, path);
  if (estimates) return estimates_table(options, points, only_model, calibration_points, path);
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
