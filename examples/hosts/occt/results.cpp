// cadinterp-occt-results: the paper's Tables 1 and 2 (§7) for the OCCT host's models, ours next
// to the paper's. Builds each model through the builder's C ABI (with the builder's default mesh
// mapper, src/mapping, where samples differ in combinatorics; elements it cannot map are
// refused and their points infeasible), then compares the asset with true regenerations at
// random points, and the interpolated meshes' volume (and the interpolated brep_volume output)
// with BRepGProp's. The calibration's per-point pairs (estimate, true error) go to
// DIR/occt_results_MODEL[_cubic]_points.tsv.
//
//   cadinterp-occt-results [--full] [--models wrench,hub,...] [--points N] [--max-samples N]
//                          [--max-depth N] [--threads N] [--seed S] [--dir DIR] [--degree 1|3]
//                          [--truth-against K=V,...] [--truth-only] [--store S]
//
// Without --full the meshes are small (a few thousand tets) so that the whole run takes minutes;
// --full uses the models' default mesh sizes.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "mesh/host_call.h"
#include "occt_host.h"
#ifdef CADINTERP_OCCT_HAVE_BEAM
#include "occt_beam.h"
#endif

namespace {

struct PaperRow {
  const char* model;
  int K, levels, samples;
  const char* mesh;
  int storage;
  double gmax, g99, fmax, f99;
};
// Tables 1 and 2 of the paper (the rows of the models we have a counterpart of).
const PaperRow kPaper[] = {
    {"wrench", 3, 5, 49, "386k", 112, 0.0028, 0.0004, 0.2138, 0.0393},
    {"hub", 3, 6, 72, "356k", 208, 0.0016, 0.0006, 0.3095, 0.0490},          // drum brake
    {"press", 4, 6, 103, "288k", 304, 0.0112, 0.0003, 0.1403, 0.0281},       // (bike frame)
    {"mount", 5, 6, 259, "291k", 1056, 0.0009, 0.0002, 0.4107, 0.1861},      // camera mount
    {"wrench_load", 3, 5, 58, "211k", 144, 0.0013, 0.0002, 0.4750, 0.2042},  // (swing)
};

const PaperRow* paper(const std::string& m) {
  for (const PaperRow& r : kPaper)
    if (m == r.model) return &r;
  return nullptr;
}

// "wrench_load": the wrench's load angle alone (vary=load_angle), the load-direction study the
// paper does with its swing; its samples share one mesh, so it builds without a mesh mapper.
std::string model_of(const std::string& m) { return m == "wrench_load" ? "wrench" : m; }
std::string extra_options(const std::string& m) {
  return m == "wrench_load" ? ",vary=load_angle" : "";
}

std::string small_options(const std::string& m) {
  const std::string fast = ",quality=2,angle=0.4";
  if (m == "wrench") return "mesh_size=8" + fast;
  if (m == "hub") return "mesh_size=16" + fast;
  if (m == "press") return "mesh_size=30" + fast;
  return "mesh_size=8" + fast;
}

double tet_volume(const float* p, const std::uint32_t* t) {
  double e[3][3];
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c)
      e[k][c] = static_cast<double>(p[3 * t[k + 1] + static_cast<std::uint32_t>(c)]) -
                static_cast<double>(p[3 * t[0] + static_cast<std::uint32_t>(c)]);
  return (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
          e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
          e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])) /
         6.0;
}

int usage() {
  std::fprintf(stderr,
               "usage: cadinterp-occt-results [--full] [--models a,b,...] [--points N]\n"
               "                              [--max-samples N] [--max-depth N] [--threads N]\n"
               "                              [--seed S] [--dir DIR] [--host-options K=V,...]\n"
               "                              [--simulate-mapped] [--canonical-refinement N]\n"
               "                              [--degree 1|3] [--truth-against K=V,...]\n"
               "                              [--truth-only] [--store S] [--map-cache MB]\n"
               "                              [--calibration-points N]\n"
               "       cadinterp-occt-results --beam\n"
               "  --host-options    appended to every model's options (e.g. order=2)\n"
               "  --simulate-mapped the builder simulates each mapped term on its mapped mesh\n"
               "                    instead of carrying the sample's fields over\n"
               "  --canonical-refinement N  rounds of canonical refinement (default 3, 0: none)\n"
               "  --threads N       the build's threads, and the truth's regenerations and\n"
               "                    simulations (default 0: every core)\n"
               "  --degree 1|3      the assets' basis: 1 linear (default), 3 cubic\n"
               "  --truth-against S also compares, at the same random points, the truth with\n"
               "                    a second host of each model with S appended to its\n"
               "                    options (e.g. mesh_size=4): the truth's own mesh term\n"
               "  --truth-only      with --truth-against: only that comparison, no build\n"
               "  --store S         keeps each model's samples in the sample store\n"
               "                    S/occt_results_MODEL.store, so that a later run of the same\n"
               "                    host options (--degree 3 after 1, other --points) reads\n"
               "                    those it needs instead of calling the host; a store of\n"
               "                    other host options is refused\n"
               "  --map-cache MB    the builder's map cache, in MiB (default: a quarter of\n"
               "                    physical memory); the assets do not depend on it\n"
               "  --calibration-points N  the builder calibrates each asset's error model on N\n"
               "                    random points of its own (default 0: the built-in factor)\n"
               "  --beam            only the FEM against beam theory (wrench handle, press spine)\n"
               "                    by element order and mesh size\n");
  return 2;
}

// The command line.
struct Args {
  bool full = false;
  std::vector<std::string> models;
  int points = 100, max_samples = -1, max_depth = -1, threads = 0;
  unsigned seed = 7;
  std::string dir = std::filesystem::temp_directory_path().string();
  std::string host_options;
  bool simulate_mapped = false;
  int canonical_refinement = -1;
  int degree = 1;
  bool beam = false;
  std::string truth_against;   // --truth-against: the reference host's extra options
  bool truth_only = false;     // --truth-only: no build, only the truth against the reference
  std::string store;           // --store: the sample stores' directory ("": none)
  int map_cache_mb = 0;        // --map-cache (0: the builder's default)
  int calibration_points = 0;  // --calibration-points
};

// Parses the command line into `a`: 0, or the exit status of a usage error (the usage printed).
int parse_args(int argc, char** argv, Args& a) {
  a.models = cadinterp::occt::model_names();
  a.models.push_back("wrench_load");
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", arg.c_str());
        std::exit(usage());
      }
      return argv[++i];
    };
    if (arg == "--full") {
      a.full = true;
    } else if (arg == "--models") {
      a.models.clear();
      std::stringstream ss(next());
      for (std::string m; std::getline(ss, m, ',');) a.models.push_back(m);
    } else if (arg == "--points") {
      a.points = std::atoi(next().c_str());
    } else if (arg == "--max-samples") {
      a.max_samples = std::atoi(next().c_str());
    } else if (arg == "--max-depth") {
      a.max_depth = std::atoi(next().c_str());
    } else if (arg == "--threads") {
      a.threads = std::atoi(next().c_str());
    } else if (arg == "--seed") {
      a.seed = static_cast<unsigned>(std::atoi(next().c_str()));
    } else if (arg == "--dir") {
      a.dir = next();
    } else if (arg == "--host-options") {
      a.host_options = next();
    } else if (arg == "--beam") {
      a.beam = true;
    } else if (arg == "--degree") {
      a.degree = std::atoi(next().c_str());
      if (a.degree != 1 && a.degree != 3) return usage();
    } else if (arg == "--truth-against") {
      a.truth_against = next();
      if (a.truth_against.empty()) return usage();
    } else if (arg == "--store") {
      a.store = next();
      if (a.store.empty()) return usage();
    } else if (arg == "--map-cache") {
      a.map_cache_mb = std::atoi(next().c_str());
      if (a.map_cache_mb < 1) return usage();
    } else if (arg == "--calibration-points") {
      a.calibration_points = std::atoi(next().c_str());
      if (a.calibration_points < 0 || a.calibration_points > CADINTERP_MAX_CALIBRATION_POINTS)
        return usage();
    } else if (arg == "--truth-only") {
      a.truth_only = true;
    } else if (arg == "--simulate-mapped") {
      a.simulate_mapped = true;
    } else if (arg == "--canonical-refinement") {
      a.canonical_refinement = std::atoi(next().c_str());
      if (a.canonical_refinement < 0 || a.canonical_refinement > 20) return usage();
    } else {
      return usage();
    }
  }
  if (a.points < 1 || (a.truth_only && a.truth_against.empty())) return usage();
  return 0;
}

// One model's build and measurements: a row of each table.
struct Row {
  std::string model, note;
  bool build_failed = false;  // note says why
  int K = 0, depth = 0, samples = 0, infeasible = 0, elements = 0, bad_elements = 0, stored = 0;
  int unmapped = 0;                          // of bad_elements: samples feasible, a term not mapped
  int simulated = 0, simulate_failures = 0;  // --simulate-mapped: mapped terms
  int refined_elements = 0, refined_vertices = 0;  // canonical refinement
  int maps = 0, maps_again = 0;                    // the builder's map cache
  int unmapped_fallbacks = 0;  // cubic elements on their corner fallback for an unmapped term
  double refinement_seconds = 0, elements_seconds = 0;
  std::string first_simulate_failure;
  double mesh_tets = 0, per_sample = 0;
  cadinterp::occt::StageTimes stages;
  bool accuracy = false;
  cadinterp::builder::AccuracyReport acc;
  int volume_points = 0;
  double volume_max = 0, host_volume_max = 0;
  double output_volume_max = -1;  // the interpolated brep_volume output's (-1: no output)
  std::string reference_options;  // --truth-against: the reference host's options
  std::string reference_note;     // why the reference could not be compared ("" if it was)
  cadinterp::builder::TruthDependenceReport reference;
};

// The host options of model `name`: the small meshes unless --full, then --host-options.
std::string options_of(const std::string& name, const Args& a) {
  std::string options = a.full ? "" : small_options(model_of(name));
  options += extra_options(name);
  if (!a.host_options.empty()) options += "," + a.host_options;
  if (!options.empty() && options[0] == ',') options.erase(0, 1);
  return options;
}

// Builds `host`'s asset at `path` and fills the row's Table 1 columns.
cadinterp::builder::BuildOutcome build_model(const std::string& name, const cadinterp_host* host,
                                             const Args& a, const std::string& path, Row& row) {
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.threads = a.threads;
  o.degree = a.degree;
  o.simulate_mapped = a.simulate_mapped ? 1 : 0;
  o.map_cache_bytes = static_cast<std::uint64_t>(a.map_cache_mb) << 20;
  o.calibration_points = a.calibration_points;
  if (a.canonical_refinement >= 0) o.canonical_refinement = a.canonical_refinement;
  o.max_samples = a.max_samples > 0 ? a.max_samples : (a.full ? 256 : 40);
  o.max_depth = a.max_depth >= 0 ? a.max_depth : (a.full ? 8 : 4);
  // One store per model, whatever the degree: a cubic build starts on the linear one's grid and
  // reads every sample the two share. The store's identity check refuses other host options.
  const std::string store = a.store.empty() ? "" : a.store + "/occt_results_" + name + ".store";
  o.store_path = store.empty() ? nullptr : store.c_str();
  row.K = host->parameter_count;
  row.depth = o.max_depth;
  // A build of a model with many parameters runs for tens of minutes (each element maps its
  // 2^K corner samples): a line at most once a minute says it is alive and how far it got.
  struct Progress {
    const std::string* name;
    double next = 60;
  } progress{&name};
  o.progress_user = &progress;
  o.progress = [](void* user, const cadinterp_progress* p) {
    auto* at = static_cast<Progress*>(user);
    if (p->seconds >= at->next) {
      std::fprintf(stderr, "  %s: %d samples done, %d queued, %d elements, %.0f s\n",
                   at->name->c_str(), p->samples_done, p->samples_queued, p->elements, p->seconds);
      at->next = p->seconds + 60;
    }
    return 0;
  };
  cadinterp::builder::BuildOutcome b = cadinterp::builder::build_asset(*host, o, path);
  row.samples = b.report.samples;
  row.infeasible = b.report.infeasible_points;
  row.elements = b.report.elements;
  row.bad_elements = b.report.infeasible_elements;
  row.unmapped = b.stages.unmapped_elements;
  row.simulated = b.stages.mapped_simulated;
  row.simulate_failures = b.stages.mapped_simulate_failures;
  row.first_simulate_failure = b.first_mapped_simulate_failure;
  row.refined_elements = b.stages.refined_elements;
  row.refined_vertices = b.stages.refined_vertices;
  row.maps = b.stages.maps;
  row.maps_again = b.stages.maps_again;
  row.unmapped_fallbacks = b.stages.unmapped_fallbacks;
  row.refinement_seconds = b.stages.refinement_seconds;
  row.elements_seconds = b.stages.elements_seconds;
  row.stored = b.report.stored_meshes;
  row.per_sample =
      b.report.host_evaluations > 0 ? b.report.host_seconds / b.report.host_evaluations : -1;
  if (!b.calibration.empty()) {
    std::fprintf(stderr, "  %s: error model calibrated on %d points, factors", name.c_str(),
                 b.stages.calibrated_points);
    for (double c : b.calibration) std::fprintf(stderr, " %.3g", c);
    std::fprintf(stderr, ", floors added");
    for (double f : b.calibration_floors) std::fprintf(stderr, " %.3g", f);
    std::fprintf(stderr, " (geometry, then each field)\n");
  }
  if (!store.empty())
    std::fprintf(stderr, "  %s: sample store %s: %d points read, %d host evaluations\n",
                 name.c_str(), store.c_str(), b.report.store_hits, b.report.host_evaluations);
  return b;
}

// The pairs the Estimate table is made of, one line per point (tab-separated, with a header):
// x by parameter name, then per quantity its estimate and its true error.
void write_points(const std::string& path, const cadinterp_host* host,
                  const cadinterp::builder::AccuracyReport& acc) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    return;
  }
  for (int d = 0; d < host->parameter_count; ++d) std::fprintf(f, "%s\t", host->parameters[d].name);
  for (std::size_t q = 0; q <= acc.field_names.size(); ++q) {
    const char* n = q ? acc.field_names[q - 1].c_str() : "geometry";
    std::fprintf(f, "%s_estimate\t%s_error%s", n, n, q < acc.field_names.size() ? "\t" : "\n");
  }
  for (const auto& p : acc.per_point) {
    for (double v : p.x) std::fprintf(f, "%.17g\t", v);
    for (std::size_t q = 0; q < p.error.size(); ++q)
      std::fprintf(f, "%.6g\t%.6g%s", p.estimate[q], p.error[q],
                   q + 1 < p.error.size() ? "\t" : "\n");
  }
  std::fclose(f);
}

// Volume of the interpolated mesh against BRepGProp's exact volume, and mean mesh size, at up to
// 20 random points.
void measure_volume(const std::string& path, const cadinterp_host* host,
                    const cadinterp::occt::Model* model, const Args& a, Row& row) {
  cadinterp_asset* asset = nullptr;
  cadinterp_workspace* ws = nullptr;
  if (cadinterp_open(path.c_str(), &asset) == CADINTERP_OK &&
      cadinterp_workspace_create(asset, &ws) == CADINTERP_OK) {
    std::mt19937 rng(a.seed + 1);
    double tets = 0;
    for (int i = 0; i < std::min(a.points, 20); ++i) {
      std::vector<double> x;
      for (int d = 0; d < row.K; ++d)
        x.push_back(std::uniform_real_distribution<double>(host->parameters[d].lower,
                                                           host->parameters[d].upper)(rng));
      cadinterp_mesh m{};
      if (cadinterp_eval(ws, x.data(), nullptr, 0, &m) != CADINTERP_OK) continue;
      const cadinterp::occt::Evaluation e = model->evaluate(x.data());
      if (!e.ok) continue;
      double v = 0;
      for (std::uint32_t t = 0; t < m.tet_count; ++t) v += tet_volume(m.positions, m.tets + 4 * t);
      row.volume_max = std::max(row.volume_max, std::abs(v / e.exact_volume - 1));
      row.host_volume_max =
          std::max(row.host_volume_max, std::abs(e.mesh_volume / e.exact_volume - 1));
      int out = -1;
      double o = 0;
      if (cadinterp_find_output(asset, "brep_volume", &out) == CADINTERP_OK &&
          cadinterp_eval_outputs(ws, x.data(), &out, 1, &o, nullptr) == CADINTERP_OK)
        row.output_volume_max = std::max(row.output_volume_max, std::abs(o / e.exact_volume - 1));
      tets += static_cast<double>(e.tets.size() / 4);
      ++row.volume_points;
    }
    if (row.volume_points > 0) row.mesh_tets = tets / row.volume_points;
  }
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
}

// The truth's regenerations run on the build's threads (0: every core).
int truth_threads(const Args& a) {
  return a.threads > 0 ? a.threads
                       : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// --truth-against: the truth of Table 2 (the host at the table's options) against a second host
// of the model with the extra options appended, at the same random points (the same seed), and
// the asset at `path` ("": none) against that second host.
void measure_truth(const std::string& name, const cadinterp_host& table, const std::string& options,
                   const std::string& path, const Args& a, Row& row) {
  row.reference_options = options + (options.empty() ? "" : ",") + a.truth_against;
  const char* error = nullptr;
  const cadinterp_host* ref =
      cadinterp_host_entry(model_of(name).c_str(), row.reference_options.c_str(), &error);
  if (!ref) {
    row.reference_note = error ? error : "the host refused the options";
    return;
  }
  std::fprintf(stderr, "%s: the truth against %s...\n", name.c_str(), ref->identity);
  try {
    const cadinterp::mesh::Host t(table), r(*ref);
    row.reference = cadinterp::builder::measure_truth_dependence(t, r, a.points, a.seed, path,
                                                                 truth_threads(a));
  } catch (const std::exception& ex) {
    row.reference_note = ex.what();
  }
}

// Builds model `name` and measures its asset into a row of `rows`; false when the host refuses
// the model (the reason printed).
bool measure_model(const std::string& name, const Args& a, std::vector<Row>& rows) {
  Row row;
  row.model = name;
  const std::string options = options_of(name, a);
  const char* error = nullptr;
  const cadinterp_host* host =
      cadinterp_host_entry(model_of(name).c_str(), options.c_str(), &error);
  if (!host) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), error);
    return false;
  }
  if (a.truth_only) {
    measure_truth(name, *host, options, "", a, row);
    rows.push_back(row);
    return true;
  }
  const cadinterp::occt::Model* model = cadinterp::occt::host_model(host);
  model->reset_stage_times();
  std::fprintf(stderr, "building %s (%s)...\n", name.c_str(), host->identity);
  const std::string path =
      a.dir + "/occt_results_" + name + (a.degree == 3 ? "_cubic" : "") + ".cadi";
  const cadinterp::builder::BuildOutcome b = build_model(name, host, a, path, row);
  row.stages = model->stage_times();
  if (b.status != CADINTERP_OK) {
    row.note = std::string(cadinterp_status_string(b.status)) + ": " + b.error;
    row.build_failed = true;
    rows.push_back(row);
    return true;
  }

  // Table 2: the asset against true regenerations at random points.
  cadinterp::mesh::Host truth(*host);
  try {
    // Also against the host's FEM on each evaluated mesh itself, which leaves out the
    // difference between the host's mesh of x and the evaluated one.
    row.acc = cadinterp::builder::measure_accuracy(path, truth, a.points, a.seed, nullptr, true,
                                                   host->simulate != nullptr, truth_threads(a));
    row.accuracy = true;
    write_points(path.substr(0, path.size() - 5) + "_points.tsv", host, row.acc);
  } catch (const std::exception& ex) {
    row.note = std::string("accuracy: ") + ex.what();
  }
  measure_volume(path, host, model, a, row);
  if (!a.truth_against.empty() && row.accuracy) measure_truth(name, *host, options, path, a, row);
  rows.push_back(row);
  return true;
}

// Table 1 (with the canonical refinement and, with --simulate-mapped, the mapped terms
// simulated), then the host's stage times.
void print_table1(const std::vector<Row>& rows, bool simulate_mapped) {
  std::printf(
      "Table 1  model        K (paper)  depth  samples (paper)  infeasible  elements (refused, "
      "unmapped)  mean tets (paper)  stored meshes (paper)  host s/sample\n");
  for (const Row& r : rows) {
    const PaperRow* p = paper(r.model);
    char per_sample[40] = "- (every sample from the store)";
    if (r.per_sample >= 0) std::snprintf(per_sample, sizeof per_sample, "%.3f", r.per_sample);
    std::printf(
        "         %-11s  %d (%d)      %d      %4d (%d)        %4d        %4d (%d, %d)"
        "                %8.0f (%s)     %5d (%d)             %s\n",
        r.model.c_str(), r.K, p ? p->K : 0, r.depth, r.samples, p ? p->samples : 0, r.infeasible,
        r.elements, r.bad_elements, r.unmapped, r.mesh_tets, p ? p->mesh : "-", r.stored,
        p ? p->storage : 0, per_sample);
  }
  for (const Row& r : rows)
    if (!r.build_failed)
      std::printf(
          "         %-11s  build stages: refinement %.0f s, elements %.0f s; %d maps (%d again "
          "after the map cache dropped them)\n",
          r.model.c_str(), r.refinement_seconds, r.elements_seconds, r.maps, r.maps_again);
  for (const Row& r : rows)
    if (r.unmapped_fallbacks > 0)
      std::printf(
          "         %-11s  cubic elements on their corner fallback, a term not mapped: %d\n",
          r.model.c_str(), r.unmapped_fallbacks);
  for (const Row& r : rows)
    if (r.refined_elements > 0)
      std::printf("         %-11s  canonical meshes refined: %d elements, %d vertices added\n",
                  r.model.c_str(), r.refined_elements, r.refined_vertices);
  if (simulate_mapped)
    for (const Row& r : rows) {
      std::printf(
          "         %-11s  mapped terms simulated on their mapped mesh: %d (%d failed, "
          "their fields carried over)\n",
          r.model.c_str(), r.simulated, r.simulate_failures);
      if (r.simulate_failures > 0)
        std::printf("         %-11s  the first failure: %s\n", "",
                    r.first_simulate_failure.c_str());
    }
  std::printf(
      "\nStage times per regeneration (s): model  regenerate  tessellate  tetgen  "
      "references  physics  (regenerations, failed)\n");
  for (const Row& r : rows) {
    const double n = std::max(1, r.stages.regenerations - r.stages.failures);
    std::printf("         %-11s  %.4f  %.4f  %.4f  %.4f  %.4f  (%d, %d)\n", r.model.c_str(),
                r.stages.regenerate / n, r.stages.tessellate / n, r.stages.tetgen / n,
                r.stages.references / n, r.stages.physics / n, r.stages.regenerations,
                r.stages.failures);
  }
}

// Table 2's FEM columns: over the simulated fields (von Mises, displacement, temperature), not
// `traction`, which is the applied load the host writes for display; |error| / the field's
// range at that point. Max: over every vertex of every point. 99%: over every vertex value of
// every point, pooled (a per-point statistic would be the max again at 100 points). The largest
// over those fields, from their per-field max and 99 % (in `names` order).
struct Fem {
  double max = 0, p99 = 0;
};
Fem fem_columns(const std::vector<std::string>& names, const std::vector<double>& max,
                const std::vector<double>& p99) {
  Fem f;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k] == "traction") continue;
    f.max = std::max(f.max, max[k]);
    f.p99 = std::max(f.p99, p99[k]);
  }
  return f;
}
Fem fem_columns(const cadinterp::builder::AccuracyReport& acc) {
  return fem_columns(acc.field_names, acc.field_max_by_field, acc.field_vertex_p99_by_field);
}

// The row's Table 2 lines past the first: per field, and against the host's FEM on each
// evaluated mesh (the interpolation's error without the two meshes' discretization difference
// the truth holds).
void print_table2_fields(const Row& r) {
  for (std::size_t k = 0; k < r.acc.field_names.size(); ++k)
    std::printf(
        "           field %-14s max %.4f  99%% of values %.4f  99%% of per-point max %.4f  "
        "(%d points)\n",
        r.acc.field_names[k].c_str(), r.acc.field_max_by_field[k],
        r.acc.field_vertex_p99_by_field[k], r.acc.field_p99_by_field[k], r.acc.field_points);
  if (r.acc.evaluated_mesh_points + r.acc.evaluated_mesh_refused > 0) {
    const Fem own = fem_columns(r.acc.field_names, r.acc.evaluated_mesh_max_by_field,
                                r.acc.evaluated_mesh_vertex_p99_by_field);
    std::printf(
        "           against the host's FEM on the evaluated mesh: FEM max %.4f  99%% %.4f  (%d "
        "points, %d not simulated%s%s)\n",
        own.max, own.p99, r.acc.evaluated_mesh_points, r.acc.evaluated_mesh_refused,
        r.acc.evaluated_mesh_refused ? ", first: " : "",
        r.acc.evaluated_mesh_first_refusal.c_str());
    for (std::size_t k = 0; k < r.acc.field_names.size(); ++k)
      std::printf("             field %-14s max %.4f  99%% of values %.4f\n",
                  r.acc.field_names[k].c_str(), r.acc.evaluated_mesh_max_by_field[k],
                  r.acc.evaluated_mesh_vertex_p99_by_field[k]);
  }
}

// Table 2: the assets' geometry and FEM error against true regenerations.
void print_table2(const std::vector<Row>& rows) {
  std::printf(
      "\nTable 2  model    points  geometry max (paper)  geometry 99%% (paper)  "
      "FEM max (paper)   FEM 99%% (paper)\n");
  for (const Row& r : rows) {
    const PaperRow* p = paper(r.model);
    if (!r.accuracy) {
      std::printf("         %-11s  n/a: %s\n", r.model.c_str(), r.note.c_str());
      continue;
    }
    const Fem fem = fem_columns(r.acc);
    if (r.acc.field_points == 0) {
      std::printf(
          "         %-11s  %d (%d infeasible, %d lost)  %.4f (%.4f)  %.4f (%.4f)  n/a: no field "
          "compared\n",
          r.model.c_str(), r.acc.points, r.acc.infeasible, r.acc.lost, r.acc.geometry_max,
          p ? p->gmax : 0, r.acc.geometry_p99, p ? p->g99 : 0);
      continue;
    }
    std::printf(
        "         %-11s  %d (%d infeasible, %d lost)  %.4f (%.4f)  %.4f (%.4f)  %.4f (%.4f)  "
        "%.4f (%.4f)\n",
        r.model.c_str(), r.acc.points, r.acc.infeasible, r.acc.lost, r.acc.geometry_max,
        p ? p->gmax : 0, r.acc.geometry_p99, p ? p->g99 : 0, fem.max, p ? p->fmax : 0, fem.p99,
        p ? p->f99 : 0);
    print_table2_fields(r);
  }
}

// The feasible space (paper §4: an element is usable when its own samples are): the share of
// the random points the runtime refuses, of those the host truly fails at, and the excess,
// points refused although the host regenerates them.
void print_feasibility(const std::vector<Row>& rows) {
  std::printf(
      "\nFeasible model    points  refused by the runtime  host fails  excess (refused, host "
      "regenerates)\n");
  for (const Row& r : rows) {
    if (!r.accuracy || r.acc.points == 0) continue;
    const double pc = 100.0 / r.acc.points;
    std::printf("         %-11s  %d     %5.1f %%                 %5.1f %%     %5.1f %%\n",
                r.model.c_str(), r.acc.points, r.acc.infeasible * pc,
                (r.acc.infeasible - r.acc.lost) * pc, r.acc.lost * pc);
  }
}

// The calibration of cadinterp_error_estimates against the true errors of Table 2, per
// quantity: the share of points where the estimate bounds the error, and the median and 10th
// percentile of estimate / true error (targets: >= 90 % bounded, median within 3x).
void print_estimates(const std::vector<Row>& rows) {
  std::printf(
      "\nEstimate model    quantity        points  bounded  median est/true  p10 est/true\n");
  for (const Row& r : rows) {
    if (!r.accuracy) continue;
    if (r.acc.estimate_points.empty()) {
      std::printf("         %-11s  n/a: the asset has no error model\n", r.model.c_str());
      continue;
    }
    for (std::size_t q = 0; q < r.acc.estimate_points.size(); ++q)
      std::printf("         %-11s  %-14s  %6d  %5.1f %%  %15.2f  %12.2f\n", r.model.c_str(),
                  q ? r.acc.field_names[q - 1].c_str() : "geometry", r.acc.estimate_points[q],
                  100 * r.acc.estimate_coverage[q], r.acc.estimate_median_ratio[q],
                  r.acc.estimate_p10_ratio[q]);
  }
}

// --truth-against: Table 2's truth against the reference host, per field and as Table 2's FEM
// columns (the simulated fields, not `traction`).
void print_truth(const std::vector<Row>& rows) {
  std::printf(
      "\nTruth    model    points (compared)  FEM max  FEM 99%%  (the table's host against the "
      "reference: the truth's own mesh term)\n");
  for (const Row& r : rows) {
    if (r.reference_options.empty()) continue;
    if (!r.reference_note.empty()) {
      std::printf("         %-11s  n/a: %s\n", r.model.c_str(), r.reference_note.c_str());
      continue;
    }
    const auto& t = r.reference;
    const Fem fem = fem_columns(t.field_names, t.max_by_field, t.vertex_p99_by_field);
    std::printf("         %-11s  %d (%d)  %.4f   %.4f   reference: %s\n", r.model.c_str(), t.points,
                t.compared, fem.max, fem.p99, r.reference_options.c_str());
    for (std::size_t k = 0; k < t.field_names.size(); ++k) {
      std::printf("           field %-14s max %.4f  99%% of values %.4f", t.field_names[k].c_str(),
                  t.max_by_field[k], t.vertex_p99_by_field[k]);
      if (t.max_by_field[k] > 0) {
        std::printf("  max at (%.2f, %.2f, %.2f), x =", t.max_at[k][0], t.max_at[k][1],
                    t.max_at[k][2]);
        for (double v : t.max_x[k]) std::printf(" %.4g", v);
      }
      std::printf("\n");
    }
    if (t.has_asset) {
      const Fem f = fem_columns(t.asset);
      std::printf(
          "           the asset against the reference (Table 2 with its truth): geometry max "
          "%.4f  99%% %.4f  FEM max %.4f  99%% %.4f  (%d points, %d infeasible)\n",
          t.asset.geometry_max, t.asset.geometry_p99, f.max, f.p99, t.asset.points,
          t.asset.infeasible);
      for (std::size_t k = 0; k < t.asset.field_names.size(); ++k)
        std::printf("             field %-14s max %.4f  99%% of values %.4f\n",
                    t.asset.field_names[k].c_str(), t.asset.field_max_by_field[k],
                    t.asset.field_vertex_p99_by_field[k]);
    }
  }
}

// The interpolated meshes' volume against the exact one.
void print_volumes(const std::vector<Row>& rows) {
  std::printf(
      "\nVolume   model    points  max |V_interp / V_exact - 1|  max |V_host_mesh / "
      "V_exact - 1|  max |output brep_volume / V_exact - 1|  (V_exact: BRepGProp)\n");
  for (const Row& r : rows) {
    if (r.volume_points == 0) {
      std::printf("         %-11s  n/a\n", r.model.c_str());
      continue;
    }
    std::printf(
        "         %-11s  %d      %.5f                        %.5f                        "
        "%.5f\n",
        r.model.c_str(), r.volume_points, r.volume_max, r.host_volume_max, r.output_volume_max);
  }
}

#ifdef CADINTERP_OCCT_HAVE_BEAM
// The physics convergence table (README "Physics"): the FEM at the box centre against beam
// theory, linear and quadratic tets, at the default mesh size and finer/coarser ones.
int print_beam_table() {
  std::printf(
      "model   order  mesh_size  tets    stress max  stress mean  curvature  evaluate s  FEM s\n");
  const struct {
    const char* model;
    double size;
  } models[] = {{"wrench", 4.0}, {"press", 12.0}};
  for (const auto& m : models)
    for (const int order : {1, 2})
      for (const double f : {3.0, 2.0, 1.0, 0.5}) {
        // P2 is within 2 % from twice the default size on; P1 is measured down to half of it.
        char options[64];
        std::snprintf(options, sizeof options, "order=%d,mesh_size=%g", order, m.size * f);
        try {
          const cadinterp::occt::BeamCheck c = cadinterp::occt::beam_check(m.model, options);
          std::printf("%-7s %d      %-9g  %-6d  %.4f      %.4f       %.4f     %.2f        %.2f\n",
                      m.model, order, m.size * f, c.tets, c.stress_max, c.stress_mean, c.curvature,
                      c.evaluate_seconds, c.simulate_seconds);
        } catch (const std::exception& e) {
          std::printf("%-7s %d      %-9g  failed: %s\n", m.model, order, m.size * f, e.what());
        }
        std::fflush(stdout);
      }
  return 0;
}
#else
int print_beam_table() {
  std::fprintf(stderr, "--beam: this build has no FEM (examples/physics)\n");
  return 1;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (const int status = parse_args(argc, argv, a)) return status;
  if (a.beam) return print_beam_table();
  std::error_code ec;
  std::filesystem::create_directories(a.dir, ec);
  if (ec) {
    std::fprintf(stderr, "cannot create --dir %s: %s\n", a.dir.c_str(), ec.message().c_str());
    return 1;
  }
  if (!a.store.empty()) std::filesystem::create_directories(a.store, ec);
  if (ec) {
    std::fprintf(stderr, "cannot create --store %s: %s\n", a.store.c_str(), ec.message().c_str());
    return 1;
  }
  std::vector<Row> rows;
  for (const std::string& name : a.models)
    if (!measure_model(name, a, rows)) return 1;

  std::printf("OCCT host results (%s meshes, %s assets; paper figures in brackets)\n",
              a.full ? "full-size" : "small", a.degree == 3 ? "cubic" : "linear");
  if (a.truth_only) {
    print_truth(rows);
    return 0;
  }
  std::printf("\n");
  print_table1(rows, a.simulate_mapped);
  print_table2(rows);
  print_feasibility(rows);
  print_estimates(rows);
  print_volumes(rows);
  if (!a.truth_against.empty()) print_truth(rows);
  // A model whose build failed (its reason in Table 2) fails the run, after the others' tables.
  const bool failed =
      std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.build_failed; });
  return failed ? 1 : 0;
}
