// cadinterp-mapping-report: measurements of the mesh mapper (paper §6) on the analytic host.
//
//   pairs  the quality table over random (source sample, canonical mesh) pairs of a model:
//          boundary Hausdorff (max, 99th percentile, relative to the bbox diagonal), min scaled
//          Jacobian, inverted tets, boundary-condition region areas, field error against the
//          closed form at the mapped points, and ms per mapping; then ms vs vertex count.
//          With --host LIB.so --model NAME [--host-options S]: any host library's model
//          (e.g. examples/hosts/occt), loaded with dlopen; field error is then n/a.
//   cubic  cubic builds with each neighbour transfer (§5.3, Fig. 15: direct, through a shared
//          sample always, direct with the bridge as fallback): how often the direct mapping of
//          a neighbour's sample fails, both routes against the sample itself, and the asset's
//          accuracy against the host.
//   sweep  builds an asset with the mesh mapper and writes a VTU sequence sweeping one
//          parameter across the box (others at the centre), to watch for flicker or jumps.
//
// One file past 800 lines: one measurement program whose subcommands share the host loading.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "builder/build.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp.h"
#include "format/asset_writer.h"
#include "mapping/boundary_untangle.h"
#include "mapping/canonical_refine.h"
#include "mapping/field_transfer.h"
#include "mapping/interior_solve.h"
#include "mapping/mapping_quality.h"
#include "mapping/mesh_mapper.h"
#include "mesh/host_call.h"
#include "mesh/surface_distance.h"
#include "tools/cli_args.h"
#include "tools/host_library.h"
#include "tools/mesh_export.h"

namespace {

using namespace cadinterp;
using Clock = std::chrono::steady_clock;

const cadinterp_host* open_host(const std::string& model, const std::string& options) {
  const char* err = nullptr;
  const cadinterp_host* h = cadinterp_host_entry(model.c_str(), options.c_str(), &err);
  if (!h) throw std::runtime_error(model + ": " + (err ? err : "cannot open the model"));
  return h;
}

// A host library's host (host_library.h). The library stays loaded for the life of the process:
// the host it returns points into it.
const cadinterp_host* open_library_host(const std::string& library, const std::string& model,
                                        const std::string& options) {
  static std::deque<tools::HostLibrary> libraries;
  return libraries.emplace_back().load(library, model, options);
}

// How two samples' B-rep topologies differ: 'T' when their faces differ (the set of triangle
// tags: faces merged, split, appeared or gone), 'E' when only B-rep vertices differ (the control
// points of IDs {0, ...}, whose IDs name their edges: an edge split or joined, as where the
// press's ram bore cuts into its fillet), '-' when neither.
char topology_change(const mesh::Sample& a, const mesh::Sample& b) {
  const std::set<std::int32_t> fa(a.triangle_tags.begin(), a.triangle_tags.end());
  const std::set<std::int32_t> fb(b.triangle_tags.begin(), b.triangle_tags.end());
  if (fa != fb) return 'T';
  auto vertices = [](const mesh::Sample& s) {
    std::set<std::vector<std::int64_t>> v;
    for (const mesh::ControlPoint& p : s.points)
      if (!p.id.empty() && p.id[0] == 0) v.insert(p.id);
    return v;
  };
  return vertices(a) != vertices(b) ? 'E' : '-';
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

// map_sample with the command's options, as the Mapper that canonical_refine.h maps through.
class OptionsMapper final : public mesh::Mapper {
 public:
  explicit OptionsMapper(const mapping::MapOptions& options) : options_(options) {}
  bool map(const mesh::Sample& source, const mesh::Sample& canonical, mesh::MappedSample& out,
           std::string& why) const override {
    return mapping::map_sample(source, canonical, out, why, nullptr, options_);
  }
  const char* name() const override { return "report"; }

 private:
  const mapping::MapOptions& options_;
};

// The options of `pairs`, as parsed.
struct PairsOptions {
  std::string model = "plate", options = "edge=5", library, host_options;
  int count = 40, seed = 1;
  std::string sizes = "8,5,3,2,1.5";
  bool sizes_given = false;
  mapping::MapOptions mo;
  int only = -1;
  double element = 0;
  std::string box;
  bool across = false, where = false, fem = false, same = false;
  std::string canonical_options;
  // The builder's defaults (cadinterp_build_options::canonical_refinement, 0.7 x its geometry
  // tolerance), so that a pair is measured as a build would store it.
  mapping::RefineOptions ro;
};

// Declares and parses the options of `pairs` into `o`; false when --help was printed.
bool parse_pairs_options(const std::vector<std::string>& args, PairsOptions& o) {
  mapping::MapOptions& mo = o.mo;
  cli::ArgParser p("cadinterp-mapping-report pairs", "",
                   "Maps random (source, canonical) sample pairs of an analytic model and prints "
                   "the quality table, then ms per mapping against the vertex count.");
  p.option("model", 'm', "NAME", "model (analytic: plate, bracket, ...; or of --host)", &o.model);
  p.option("options", 'o', "K=V,...", "the model's options", &o.options);
  p.option("pairs", 'n', "N", "random pairs", &o.count, 1, 100000);
  p.option("seed", 's', "N", "random seed", &o.seed, 0, 1 << 30);
  p.option("only", 0, "I", "map pair I (0-based) of the sequence only, to reproduce one", &o.only,
           0, 100000);
  p.option("element", 0, "F",
           "pairs as the builder makes them: a random box of F times the domain's size in every "
           "parameter (a K-d tree element F = 2^-depth across), the canonical at its centre and "
           "the source at one of its corners (0: two independent random points)",
           &o.element, 0.0, 1.0);
  p.option("box", 0, "LO:HI,...",
           "map every corner of this parameter box onto its centre, as the builder maps a linear "
           "element's terms (one LO:HI per parameter; -n is then 2^K and --only picks a corner, "
           "bit d set for the upper side of parameter d)",
           &o.box);
  p.flag("across", 0,
         "map only pairs across a B-rep topology change ('T' or 'E' in the topo column), drawing "
         "up to 200 x N random pairs until N are found",
         &o.across);
  p.flag("where", 0,
         "after each pair, where its Hausdorff maximum lies: the vertex, its face tag, and "
         "whether it is a source vertex far from the mapped boundary or a mapped one off the "
         "source's",
         &o.where);
  p.flag("fem", 0,
         "compare the fields each mapping carries with the host's own simulate at the source's "
         "parameters on the mapped mesh (its boundary-condition faces found by the canonical's "
         "region tags), instead of with the closed form: per field after each pair and in the "
         "summary",
         &o.fem);
  p.option("canonical-options", 0, "STRING",
           "the model's options for the canonical sample (default: the source's), e.g. another "
           "mesh size",
           &o.canonical_options);
  p.flag("same", 0,
         "the canonical at the source's parameters: with --canonical-options, one solid meshed "
         "twice (the fields' difference then is the two meshes' alone)",
         &o.same);
  p.option("sizes", 0, "MM,...", "plate edge lengths for the timing table ('' for none)", &o.sizes);
  p.option("host", 0, "LIB.so",
           "a host library (its " CADINTERP_HOST_ENTRY_NAME " entry) instead of the analytic host",
           &o.library);
  p.option("host-options", 0, "STRING", "the model's options for --host", &o.host_options);
  p.option("relax", 0, "N", "sweeps of the in-patch relaxation (0: none)", &mo.relax_iterations, 0,
           100000);
  int stiffen = 0;
  p.option("interior-steps", 0, "N", "boundary increments of the interior solve",
           &mo.interior_steps, 1, 1000);
  p.option("stiffen", 0, "E", "stiffness x (mean tet volume / volume)^E in the interior solve",
           &stiffen, 0, 4);
  p.option("fallback-steps", 0, "N",
           "increments of the second interior solve where tets stay inverted (0: none)",
           &mo.fallback_steps, 0, 1000);
  p.option("boundary-passes", 0, "N",
           "passes of boundary untangling (surface vertices moved within the source surface, "
           "then the interior again) where tets stay inverted (0: none)",
           &mo.boundary_untangle_passes, 0, 100);
  p.option("smooth", 0, "A",
           "Phong shape factor of the source reconstruction the boundary is placed on (0: the "
           "flat source triangles)",
           &mo.smooth_alpha, 0.0, 1.0);
  p.option("subdivide", 0, "R",
           "subdivide patches by paths shorter than R times the way round their loop (0: none)",
           &mo.subdivide_ratio, 0.0, 1.0);
  p.option("subdivide-retry", 0, "R",
           "where tets stay inverted after every other retry, map once more with --subdivide R "
           "(0: no such retry)",
           &mo.subdivide_retry_ratio, 0.0, 1.0);
  int geodesic = 1;
  p.option("geodesic", 0, "0|1",
           "measure traced layout paths along their geodesics (1) or their mesh edges (0)",
           &geodesic, 0, 1);
  int foldover_free = 1;
  p.option("foldover-free", 0, "0|1",
           "untangle the interior near tets that stay inverted as a whole (1) or not (0)",
           &foldover_free, 0, 1);
  int planar = 1;
  p.option("planar", 0, "0|1",
           "lay flat patches whose surface map folds into their plane (1) or not (0)", &planar, 0,
           1);
  mapping::RefineOptions& ro = o.ro;
  p.option("refine", 0, "N",
           "rounds of canonical refinement (canonical_refine.h), as the builder does by default: "
           "boundary edges bisected where the mapped surface departs from the source's by more "
           "than --refine-tolerance, the pair mapped again (0: none, the canonical as the host "
           "meshed it)",
           &ro.rounds, 0, 20);
  p.option("refine-tolerance", 0, "F", "departure (/ bbox diagonal) above which --refine bisects",
           &ro.tolerance, 1e-6, 1.0);
  p.option("refine-growth", 0, "F", "--refine adds at most F times the canonical's vertex count",
           &ro.max_growth, 0.0, 100.0);
  if (!p.parse(args)) return false;
  mo.planar_patches = planar != 0;
  mo.foldover_free = foldover_free != 0;
  mo.stiffening = stiffen;
  mo.geodesic_paths = geodesic != 0;
  for (const std::string& a : args) o.sizes_given = o.sizes_given || a.rfind("--sizes", 0) == 0;
  return true;
}

// --box LO:HI,...: one range per parameter of a host with `dim` parameters.
void parse_box(const std::string& box, int dim, std::vector<double>& box_lo,
               std::vector<double>& box_hi) {
  for (const std::string& r : cli::split_list(box)) {
    double lo = 0, hi = 0;
    char tail = 0;
    if (std::sscanf(r.c_str(), "%lf:%lf%c", &lo, &hi, &tail) != 2 || !(lo <= hi))
      throw std::runtime_error("--box: '" + r + "' is not LO:HI with LO <= HI");
    box_lo.push_back(lo);
    box_hi.push_back(hi);
  }
  if (static_cast<int>(box_lo.size()) != dim)
    throw std::runtime_error("--box: " + std::to_string(box_lo.size()) + " ranges for " +
                             std::to_string(dim) + " parameters");
}

// What `pairs` adds up over the pairs it maps, for the summary.
struct PairTotals {
  std::vector<double> haus, haus99, area, field, field99, times, sizes_v;
  std::map<std::string, std::pair<double, std::vector<double>>> fem_by_field;  // max, p99s
  std::size_t simulated = 0;
  double min_sj = 1;
  std::size_t inverted = 0, failed = 0, differing = 0, topology = 0, edges_only = 0, infeasible = 0;
  int found = 0;
};

// One run of `pairs`: the hosts, the pair drawing and the totals the pairs add to.
struct PairsRun {
  const PairsOptions& o;
  const mesh::Host& host;
  const mesh::Host& canonical_host;
  const analytic_model* am;  // the analytic model (closed-form fields), or null
  const OptionsMapper& with_options;
  std::vector<double> box_lo, box_hi;  // --box, or empty
  std::mt19937 rng;
  PairTotals t;

  std::vector<double> random_x();
  void draw(int i, std::vector<double>& xa, std::vector<double>& xc);
  void print_x(const char* name, const std::vector<double>& x) const;
  void pair(int i, const std::vector<double>& xa, const std::vector<double>& xc);
  std::string compare_with_simulate(const std::vector<double>& xa, const mesh::Sample& a,
                                    const mesh::Sample& cm, const mesh::MappedSample& m,
                                    mapping::PairQuality& q, bool& fields_measured);
  void record(int i, const std::vector<double>& xa, const mesh::Sample& a, const mesh::Sample& c,
              const mesh::Sample& cm, const mesh::MappedSample& m, char topo, double ms,
              const mapping::RefineStats& rs);
};

std::vector<double> PairsRun::random_x() {
  std::vector<double> x(static_cast<std::size_t>(host.dim()));
  for (std::size_t d = 0; d < x.size(); ++d)
    x[d] = std::uniform_real_distribution<double>(host.lower()[d], host.upper()[d])(rng);
  return x;
}

// Pair i's source and canonical parameters. Every pair draws two random points, skipped or not,
// so that pair i is the same with or without --only.
void PairsRun::draw(int i, std::vector<double>& xa, std::vector<double>& xc) {
  xa = random_x();
  xc = random_x();
  if (!box_lo.empty()) {
    for (std::size_t d = 0; d < xa.size(); ++d) {
      xc[d] = 0.5 * (box_lo[d] + box_hi[d]);
      xa[d] = (i >> d) & 1 ? box_hi[d] : box_lo[d];
    }
  } else if (o.element > 0) {
    // xa picks the box's position, xc's coordinates the corner (below or above the centre).
    for (std::size_t d = 0; d < xa.size(); ++d) {
      const double lo = host.lower()[d], hi = host.upper()[d], half = 0.5 * o.element * (hi - lo);
      const double centre = lo + half + (xa[d] - lo) * (1 - o.element);
      const bool upper = xc[d] > 0.5 * (lo + hi);
      xc[d] = centre;
      xa[d] = centre + (upper ? half : -half);
    }
  }
  if (o.same) xc = xa;
}

// Every digit, so that a test can regenerate the pair exactly (the meshes of two samples whose
// parameters differ in the seventh digit may differ).
void PairsRun::print_x(const char* name, const std::vector<double>& x) const {
  std::printf("%s x =", name);
  for (std::size_t d = 0; d < x.size(); ++d)
    std::printf(" %s=%.17g", host.names()[d].c_str(), x[d]);
  std::printf("\n");
}

// Evaluates and maps the pair (xa -> xc): skipped when a sample is infeasible or, with --across,
// when the topology is the same; a failed mapping is a row of its own.
void PairsRun::pair(int i, const std::vector<double>& xa, const std::vector<double>& xc) {
  const mesh::Sample a = host.evaluate(xa.data()), c = canonical_host.evaluate(xc.data());
  if (!a.feasible || !c.feasible) {
    ++t.infeasible;
    return;
  }
  const char topo = topology_change(a, c);
  if (o.across && topo == '-') return;
  t.differing += mesh::same_combinatorics(a, c) ? 0 : 1;
  ++t.found;
  t.topology += topo == 'T' ? 1 : 0;
  t.edges_only += topo == 'E' ? 1 : 0;
  mesh::MappedSample m;
  std::string why;
  const auto t0 = Clock::now();
  // With --refine the pair is measured on the refined canonical `cr`.
  mesh::Sample cr;
  mapping::RefineStats rs;
  bool ok;
  if (o.ro.rounds > 0) {
    std::vector<mesh::MappedSample> onto;
    ok = mapping::refine_canonical({&a}, c, with_options, cr, onto, why, &rs, o.ro);
    if (ok) m = std::move(onto[0]);
  } else {
    ok = mapping::map_sample(a, c, m, why, nullptr, o.mo);
  }
  const mesh::Sample& cm = o.ro.rounds > 0 && ok ? cr : c;
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (!ok) {
    ++t.failed;
    std::printf("%5d %6zu %6zu %4c %8.2f FAILED: %s\n", i, a.vertex_count(), c.vertex_count(), topo,
                ms, why.c_str());
    return;
  }
  record(i, xa, a, c, cm, m, topo, ms, rs);
}

// --fem: the fields the mapping carries against the host's simulate at the source's parameters on
// the mapped mesh. The row's field columns become the largest of the fields' max and of their
// 99th percentiles; returns the per-field text, or why nothing was simulated.
std::string PairsRun::compare_with_simulate(const std::vector<double>& xa, const mesh::Sample& a,
                                            const mesh::Sample& cm, const mesh::MappedSample& m,
                                            mapping::PairQuality& q, bool& fields_measured) {
  std::string by_field;
  q.field_max = q.field_p99 = 0;
  mesh::Sample mesh;
  std::string no;
  if (!mapping::mesh_for_simulation(a, cm, m.vertices, mesh, no)) {
    by_field = "not simulated: " + no;
  } else if (const mesh::Sample r = host.simulate(xa.data(), mesh); !r.feasible) {
    by_field = "not simulated: " + r.message;
  } else {
    for (const mapping::FieldError& e : mapping::compare_fields(a, m, r)) {
      q.field_max = std::max(q.field_max, e.max);
      q.field_p99 = std::max(q.field_p99, e.p99);
      char one[96];
      std::snprintf(one, sizeof one, "%s %.2e / %.2e", e.name.c_str(), e.max, e.p99);
      by_field += (by_field.empty() ? "" : ", ") + std::string(one);
      auto& [fm, f9] = t.fem_by_field[e.name];
      fm = std::max(fm, e.max);
      f9.push_back(e.p99);
    }
    ++t.simulated;
    fields_measured = true;
  }
  return by_field;
}

// Measures a mapped pair (source a, canonical c, refined canonical cm), prints its row and adds it
// to the totals.
void PairsRun::record(int i, const std::vector<double>& xa, const mesh::Sample& a,
                      const mesh::Sample& c, const mesh::Sample& cm, const mesh::MappedSample& m,
                      char topo, double ms, const mapping::RefineStats& rs) {
  mapping::PairQuality q = mapping::measure_pair(
      a, cm, m,
      am ? mapping::FieldTruth([&](int f, const double* pt, double* v) {
        return analytic_model_field_at(am, f, xa.data(), pt, v) == CADINTERP_OK;
      })
         : mapping::FieldTruth());
  // The canonical mesh's own quality, for comparison: the mapping cannot do better.
  const double own = mapping::tet_quality(cm.vertices, cm.tets).min_scaled_jacobian;
  char fmax[16] = "n/a", f99[16] = "n/a";
  std::string by_field;
  bool fields_measured = am != nullptr && !o.fem;
  if (o.fem) by_field = compare_with_simulate(xa, a, cm, m, q, fields_measured);
  if (fields_measured) {
    std::snprintf(fmax, sizeof fmax, "%.2e", q.field_max);
    std::snprintf(f99, sizeof f99, "%.2e", q.field_p99);
  }
  std::printf("%5d %6zu %6zu %4c %8.2f %10.2e %10.2e %8.3f %8.3f %4zu %9.2e %10s %10s\n", i,
              a.vertex_count(), c.vertex_count(), topo, ms, q.hausdorff_max, q.hausdorff_p99,
              q.min_scaled_jacobian, own, q.inverted, q.region_area_error, fmax, f99);
  if (o.fem)
    std::printf("      fields (max / p99) against the host's simulate on the mapped mesh: %s\n",
                by_field.c_str());
  if (o.ro.rounds > 0)
    std::printf(
        "      refined: %d rounds, +%zu canonical vertices (%zu), departure %.2e -> %.2e%s%s\n",
        rs.rounds, rs.added_vertices, cm.vertex_count(), rs.before, rs.after,
        rs.stopped.empty() ? "" : "; stopped by ", rs.stopped.c_str());
  if (o.where)
    std::printf("      Hausdorff max at (%.4g, %.4g, %.4g): %s vertex on face tag %d\n",
                q.hausdorff_at[0], q.hausdorff_at[1], q.hausdorff_at[2],
                q.hausdorff_at_source ? "a source" : "a mapped", q.hausdorff_tag);
  t.times.push_back(ms);
  t.sizes_v.push_back(static_cast<double>(cm.vertex_count()));
  t.haus.push_back(q.hausdorff_max);
  t.haus99.push_back(q.hausdorff_p99);
  t.area.push_back(q.region_area_error);
  t.field.push_back(q.field_max);
  t.field99.push_back(q.field_p99);
  t.min_sj = std::min(t.min_sj, q.min_scaled_jacobian);
  t.inverted += q.inverted;
}

// The summary lines under the pairs' table.
void print_pairs_summary(const PairTotals& t, bool fem, const analytic_model* am) {
  auto mx = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  };
  std::printf(
      "summary: %zu mapped (%zu with differing combinatorics, %zu across a B-rep face change, %zu "
      "across an edge or vertex change only), %zu failed, %zu pairs skipped (a sample "
      "infeasible); Hausdorff max %.2e, "
      "p99 over pairs of per-pair p99 %.2e (target 1e-3); min scaled Jacobian %.3f; inverted %zu;"
      " region area error max %.2e (target 1e-2); ",
      t.haus.size(), t.differing, t.topology, t.edges_only, t.failed, t.infeasible, mx(t.haus),
      percentile(t.haus99, 0.99), t.min_sj, t.inverted, mx(t.area));
  if (fem) {
    std::printf(
        "fields against the host's simulate on the mapped mesh (%zu of %zu mapped pairs "
        "simulated), max / p99 over pairs of per-pair p99:",
        t.simulated, t.haus.size());
    for (const auto& [name, e] : t.fem_by_field)
      std::printf(" %s %.2e / %.2e", name.c_str(), e.first, percentile(e.second, 0.99));
    std::printf("\n");
  } else if (am)
    std::printf("field error max %.2e, p99 %.2e\n", mx(t.field), percentile(t.field99, 0.99));
  else
    std::printf(
        "field error n/a (no closed-form truth for this host; --fem compares with its "
        "simulate on the mapped mesh)\n");
  if (!t.times.empty()) {
    double tsum = 0, vsum = 0;
    for (std::size_t i = 0; i < t.times.size(); ++i) {
      tsum += t.times[i];
      vsum += t.sizes_v[i];
    }
    std::printf(
        "time per mapping: mean %.1f ms, max %.1f ms, at mean V_can %.0f (%.1f us per "
        "canonical vertex)\n",
        tsum / double(t.times.size()), mx(t.times), vsum / double(t.times.size()),
        1e3 * tsum / vsum);
  }
}

// ms per mapping against the vertex count: the plate at one shape pair, finer and finer.
void print_timing_table(const std::string& sizes, const mapping::MapOptions& mo) {
  const std::vector<std::string> edges = cli::split_list(sizes);
  if (!edges.empty()) {
    std::printf("\ntiming (plate, source (60,30,6) -> canonical (80,45,8), same edge length)\n");
    std::printf("%8s %8s %8s %8s %10s\n", "edge_mm", "V_src", "V_can", "T_can", "ms/map");
  }
  for (const std::string& e : edges) {
    const cadinterp_host* ph = open_host("plate", "edge=" + e);
    const mesh::Host plate(*ph);
    const double xa[3] = {60, 30, 6}, xc[3] = {80, 45, 8};
    const mesh::Sample a = plate.evaluate(xa), c = plate.evaluate(xc);
    mesh::MappedSample m;
    std::string why;
    int reps = 0;
    const auto t0 = Clock::now();
    do {
      if (!mapping::map_sample(a, c, m, why, nullptr, mo)) {
        std::printf("%8s FAILED: %s\n", e.c_str(), why.c_str());
        break;
      }
      ++reps;
    } while (std::chrono::duration<double>(Clock::now() - t0).count() < 0.5 && reps < 50);
    const double ms =
        std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / std::max(1, reps);
    std::printf("%8s %8zu %8zu %8zu %10.2f\n", e.c_str(), a.vertex_count(), c.vertex_count(),
                c.tet_count(), ms);
  }
}

int pairs(const std::vector<std::string>& args) {
  PairsOptions o;
  if (!parse_pairs_options(args, o)) return 0;
  const OptionsMapper with_options(o.mo);

  // Field truth in closed form exists for the analytic host only. Another host's own fields at
  // the mapped points are what the transfer interpolates, so comparing with them would measure
  // nothing: its fields are n/a unless --fem asks it to simulate on the mapped mesh itself, a
  // truth that also holds the difference between two meshes' discretizations of the same field.
  const bool analytic = o.library.empty();
  if (!analytic) o.options = o.host_options;
  if (!analytic && !o.sizes_given) o.sizes.clear();
  const cadinterp_host* h =
      analytic ? open_host(o.model, o.options) : open_library_host(o.library, o.model, o.options);
  const mesh::Host host(*h);
  const analytic_model* am = analytic ? analytic_host_model(h) : nullptr;
  const bool other = !o.canonical_options.empty() && o.canonical_options != o.options;
  const mesh::Host canonical_host(
      !other     ? *h
      : analytic ? *open_host(o.model, o.canonical_options)
                 : *open_library_host(o.library, o.model, o.canonical_options));
  PairsRun run{o,
               host,
               canonical_host,
               am,
               with_options,
               {},
               {},
               std::mt19937(static_cast<unsigned>(o.seed)),
               {}};
  if (!o.box.empty()) {
    parse_box(o.box, host.dim(), run.box_lo, run.box_hi);
    o.count = 1 << host.dim();
  }
  std::printf("model %s (%s)%s%s, %d random pairs%s%s%s%s\n", o.model.c_str(), o.options.c_str(),
              analytic ? "" : " from ", analytic ? "" : o.library.c_str(), o.count,
              o.element > 0 ? " (element corner -> centre)" : "",
              other ? ", the canonical's options (" : "", other ? o.canonical_options.c_str() : "",
              other ? ")" : "");
  if (o.same) std::printf("the canonical at the source's parameters\n");
  std::printf("%5s %6s %6s %4s %8s %10s %10s %8s %8s %4s %9s %10s %10s\n", "pair", "V_src", "V_can",
              "topo", "ms", "haus_max", "haus_p99", "min_sj", "can_sj", "inv", "area_err",
              "field_max", "field_p99");
  const int count = o.count;
  for (int i = 0;
       o.across && run.box_lo.empty() ? run.t.found < count && i < 200 * count : i < count; ++i) {
    std::vector<double> xa, xc;
    run.draw(i, xa, xc);
    if (o.only >= 0 && i != o.only) continue;
    if (o.only >= 0) {
      run.print_x("source", xa);
      run.print_x("canonical", xc);
    }
    run.pair(i, xa, xc);
  }
  print_pairs_summary(run.t, o.fem, am);
  print_timing_table(o.sizes, o.mo);
  return run.t.failed ? 1 : 0;
}

int cubic(const std::vector<std::string>& args) {
  std::string model = "plate", options = "edge=8", out_dir = "/tmp";
  int samples = 200, points = 60, threads = 2, compare = 1;
  cli::ArgParser p("cadinterp-mapping-report cubic", "",
                   "Cubic builds of an analytic model with each neighbour transfer (paper §5.3, "
                   "Fig. 15); prints how the direct mapping and the shared-sample bridge compare "
                   "on every neighbour sample, and each asset's accuracy against the host.");
  p.option("model", 'm', "NAME", "analytic model", &model);
  p.option("options", 'o', "K=V,...", "the model's options", &options);
  p.option("samples", 0, "N", "the build's sample budget", &samples, 2, 100000);
  p.option("points", 0, "N", "random points for the accuracy", &points, 1, 100000);
  p.option("threads", 0, "N", "build threads", &threads, 1, 256);
  p.option("out", 0, "DIR", "where the assets go", &out_dir);
  p.option("compare", 0, "0|1",
           "compute both routes for every neighbour sample (0: build times without it)", &compare,
           0, 1);
  if (!p.parse(args)) return 0;
  const cadinterp_host* h = open_host(model, options);
  const mesh::Host host(*h);
  const analytic_model* am = analytic_host_model(h);
  std::printf("model %s (%s), cubic, %d samples\n", model.c_str(), options.c_str(), samples);
  std::printf("%-9s %7s %7s %8s %7s %7s %7s | %8s %8s %10s %10s %10s %10s %7s %7s | %9s %9s %9s\n",
              "transfer", "build_s", "samples", "elements", "infeas", "nb_term", "dir_fail",
              "bridged", "br_fail", "dir_h_mean", "br_h_mean", "dir_h_max", "br_h_max", "dir_sj",
              "br_sj", "geom_max", "geom_p99", "temp_max");
  const std::pair<builder::NeighbourTransfer, const char*> modes[] = {
      {builder::NeighbourTransfer::Direct, "direct"},
      {builder::NeighbourTransfer::Always, "always"},
      {builder::NeighbourTransfer::Fallback, "fallback"}};
  for (const auto& [mode, name] : modes) {
    builder::BuildOptions o;
    o.degree = core::Degree::Cubic;
    o.max_samples = samples;
    o.threads = threads;
    o.neighbour_transfer = mode;
    o.measure_neighbour_transfer = compare != 0;
    builder::BuildResult r = builder::build(host, o);
    const std::string path = out_dir + "/cadinterp-cubic-" + model + "-" + name + ".cadi";
    format::write_asset_file(r.content, builder::asset_write_options(o), path);
    const builder::AccuracyReport a = builder::measure_accuracy(
        path, host, points, 7, [am](int f, const double* x, const double* pt, double* v) {
          return f == 0 && analytic_model_field_at(am, f, x, pt, v) == CADINTERP_OK;
        });
    const builder::NeighbourTransferStats& st = r.neighbour;
    const double c = std::max(1, st.compared);
    std::printf(
        "%-9s %7.1f %7d %8d %7d %7d %7d | %8d %8d %10.2e %10.2e %10.2e %10.2e %7.3f %7.3f | %9.2e "
        "%9.2e "
        "%9.2e\n",
        name, r.report.wall_seconds, r.report.samples, r.report.elements,
        r.report.infeasible_elements, st.neighbour_terms, st.direct_failed, st.bridged,
        st.bridge_failed, st.direct_hausdorff_sum / c, st.bridged_hausdorff_sum / c,
        st.direct_hausdorff_max, st.bridged_hausdorff_max, st.direct_min_sj, st.bridged_min_sj,
        a.geometry_max, a.geometry_p99, a.field_max);
    std::printf(
        "          (%d terms compared; bridge better on %d; bridged results with inverted "
        "tets: %d)\n",
        st.compared, st.bridged_better, st.bridge_inverted);
    std::filesystem::remove(path);
  }
  return 0;
}

int sweep(const std::vector<std::string>& args) {
  std::string model = "plate", options = "edge=5", out_dir, library, host_options;
  int parameter = 0, steps = 24, samples = 120, threads = 1;
  cli::ArgParser p("cadinterp-mapping-report sweep", "",
                   "Builds an asset with the mesh mapper, then writes OUT/sweep_NNN.vtu sweeping "
                   "one parameter from its lower to its upper bound (others at the centre of "
                   "the box), across several elements. Prints, per frame, its element and how far "
                   "its surface lies from the previous frame's (symmetric Hausdorff over the "
                   "bbox diagonal): a smooth sweep moves by about the same amount each step, a "
                   "jump or flicker shows as a spike.");
  p.option("model", 'm', "NAME", "model (analytic, or of --host)", &model);
  p.option("options", 'o', "K=V,...", "the analytic model's options", &options);
  p.option("host", 0, "LIB.so",
           "a host library (its " CADINTERP_HOST_ENTRY_NAME " entry) instead of the analytic host",
           &library);
  p.option("host-options", 0, "STRING",
           "the model's options for --host (e.g. the OpenCASCADE host's vary=NAME builds over "
           "that parameter alone)",
           &host_options);
  p.option("parameter", 'p', "D", "the parameter to sweep (index)", &parameter, 0, 63);
  p.option("steps", 'n', "N", "frames", &steps, 2, 10000);
  p.option("samples", 0, "N", "the build's sample budget", &samples, 2, 100000);
  p.option("threads", 0, "N", "the build's host threads", &threads, 1, 256);
  p.option("out", 0, "DIR", "output directory", &out_dir).required();
  if (!p.parse(args)) return 0;
  const cadinterp_host* h =
      library.empty() ? open_host(model, options) : open_library_host(library, model, host_options);
  // Checked before the build, which can take minutes.
  if (parameter >= h->parameter_count)
    throw cli::UsageError("--parameter must be below " + std::to_string(h->parameter_count) +
                          ", the model's parameter count");
  std::filesystem::create_directories(out_dir);
  const std::string asset_path = out_dir + "/sweep.cadi";
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = samples;
  o.threads = threads;
  const builder::BuildOutcome r = builder::build_asset(*h, o, asset_path);
  if (r.status != CADINTERP_OK) throw std::runtime_error("build failed: " + r.error);
  std::printf("built %s: %d samples, %d elements (%d infeasible)\n", asset_path.c_str(),
              r.report.samples, r.report.elements, r.report.infeasible_elements);
  cadinterp_asset* asset = nullptr;
  if (cadinterp_open(asset_path.c_str(), &asset) != CADINTERP_OK)
    throw std::runtime_error(std::string("cannot open the asset: ") + cadinterp_open_error());
  cadinterp_workspace* ws = nullptr;
  cadinterp_workspace_create(asset, &ws);
  const int K = cadinterp_parameter_count(asset);
  std::vector<double> lo(static_cast<std::size_t>(K)), hi(lo.size()), x(lo.size());
  for (int d = 0; d < K; ++d) {
    cadinterp_parameter_info info;
    cadinterp_parameter(asset, d, &info);
    lo[static_cast<std::size_t>(d)] = info.lower;
    hi[static_cast<std::size_t>(d)] = info.upper;
    x[static_cast<std::size_t>(d)] = 0.5 * (info.lower + info.upper);
  }
  std::vector<int> fields;
  for (int f = 0; f < cadinterp_field_count(asset); ++f) fields.push_back(f);
  std::vector<double> previous;
  std::vector<std::uint32_t> previous_triangles;
  std::vector<double> moves;
  for (int i = 0; i < steps; ++i) {
    const auto d = static_cast<std::size_t>(parameter);
    x[d] = lo[d] + (hi[d] - lo[d]) * i / (steps - 1);
    cadinterp_mesh m;
    if (cadinterp_eval(ws, x.data(), fields.data(), static_cast<int>(fields.size()), &m) !=
        CADINTERP_OK) {
      std::printf("step %3d x[%d]=%-10.4g %s\n", i, parameter, x[d], cadinterp_workspace_error(ws));
      previous.clear();
      continue;
    }
    cli::ExportMesh em =
        cli::export_mesh_of(asset, m, fields.data(), static_cast<int>(fields.size()));
    em.generator = "cadinterp-mapping-report sweep";
    char name[64];
    std::snprintf(name, sizeof name, "/sweep_%03d.vtu", i);
    cli::write_vtu(out_dir + name, em, cli::VtuEncoding::Base64);
    std::vector<double> now(m.positions, m.positions + 3 * std::size_t(m.vertex_count));
    std::vector<std::uint32_t> triangles(m.triangles,
                                         m.triangles + 3 * std::size_t(m.triangle_count));
    double move = -1;
    if (!previous.empty()) {
      double lo3[3] = {1e300, 1e300, 1e300}, hi3[3] = {-1e300, -1e300, -1e300};
      for (std::size_t v = 0; v < now.size(); ++v) {
        lo3[v % 3] = std::min(lo3[v % 3], now[v]);
        hi3[v % 3] = std::max(hi3[v % 3], now[v]);
      }
      const double diag = std::hypot(hi3[0] - lo3[0], hi3[1] - lo3[1], hi3[2] - lo3[2]);
      move = mesh::symmetric_hausdorff(previous, previous_triangles, now, triangles) / diag;
      moves.push_back(move);
    }
    previous = std::move(now);
    previous_triangles = std::move(triangles);
    char moved[32] = "(first)";
    if (move >= 0) std::snprintf(moved, sizeof moved, "%.3e", move);
    std::printf("step %3d x[%d]=%-10.4g element %-5d V=%-6u surface move %s\n", i, parameter, x[d],
                m.element, m.vertex_count, moved);
  }
  if (!moves.empty()) {
    std::vector<double> sorted = moves;
    std::sort(sorted.begin(), sorted.end());
    std::printf("surface move per step: median %.3e, max %.3e (%.1fx the median)\n",
                sorted[sorted.size() / 2], sorted.back(),
                sorted.back() / std::max(sorted[sorted.size() / 2], 1e-300));
  }
  cadinterp_workspace_destroy(ws);
  cadinterp_close(asset);
  return 0;
}

// The host's own meshes: the tets no mapping can keep valid are the flat ones whose four
// vertices all lie on the boundary (the surface map moves each face on its own, and only
// interior vertices are free to follow), so they are counted apart.
int meshes(const std::vector<std::string>& args) {
  std::string model = "plate", options, library;
  int count = 10, seed = 1;
  double flat = 0.05;
  cli::ArgParser p("cadinterp-mapping-report meshes", "",
                   "Evaluates a model at random points and prints its meshes' quality: the "
                   "smallest scaled Jacobian, and the tets below --flat, all of them and those "
                   "with all four vertices on the boundary.");
  p.option("model", 'm', "NAME", "model (analytic: plate, bracket, ...; or of --host)", &model);
  p.option("options", 'o', "K=V,...", "the model's options", &options);
  p.option("points", 'n', "N", "random points", &count, 1, 100000);
  p.option("seed", 's', "N", "random seed", &seed, 0, 1 << 30);
  p.option("flat", 0, "SJ", "scaled Jacobian below which a tet counts as flat", &flat, 0.0, 1.0);
  p.option("host", 0, "LIB.so", "a host library instead of the analytic host", &library);
  if (!p.parse(args)) return 0;
  const cadinterp_host* h =
      library.empty() ? open_host(model, options) : open_library_host(library, model, options);
  const mesh::Host host(*h);
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::printf("%6s %7s %8s %8s %10s %7s %7s\n", "V", "T", "min_sj", "flat", "flat_bdry", "F",
              "F<15deg");
  std::size_t total_flat = 0, total_bdry = 0, total_tets = 0;
  for (int i = 0; i < count; ++i) {
    std::vector<double> x(static_cast<std::size_t>(host.dim()));
    for (std::size_t d = 0; d < x.size(); ++d)
      x[d] = std::uniform_real_distribution<double>(host.lower()[d], host.upper()[d])(rng);
    const mesh::Sample s = host.evaluate(x.data());
    if (!s.feasible) {
      std::printf("infeasible: %s\n", s.message.c_str());
      continue;
    }
    std::vector<char> on_boundary(s.vertex_count(), 0);
    for (std::uint32_t v : s.triangles) on_boundary[v] = 1;
    double min_sj = 1;
    std::size_t nflat = 0, nbdry = 0;
    for (std::size_t t = 0; t < s.tets.size(); t += 4) {
      const double sj = mapping::scaled_jacobian(s.vertices, &s.tets[t]);
      min_sj = std::min(min_sj, sj);
      if (sj >= flat) continue;
      ++nflat;
      bool all = true;
      for (int k = 0; k < 4; ++k) all = all && on_boundary[s.tets[t + std::size_t(k)]];
      nbdry += all ? 1 : 0;
    }
    // Boundary triangles with an angle under 15 degrees: a tet on such a face is flat at that
    // corner whatever its fourth vertex.
    std::size_t skinny = 0;
    for (std::size_t f = 0; f < s.triangles.size(); f += 3) {
      double m = 180;
      for (int k = 0; k < 3; ++k) {
        const double* a = &s.vertices[3 * std::size_t(s.triangles[f + std::size_t(k)])];
        const double* b = &s.vertices[3 * std::size_t(s.triangles[f + std::size_t((k + 1) % 3)])];
        const double* c = &s.vertices[3 * std::size_t(s.triangles[f + std::size_t((k + 2) % 3)])];
        double u[3], w[3];
        for (int d = 0; d < 3; ++d) u[d] = b[d] - a[d], w[d] = c[d] - a[d];
        const double dot = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
        const double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2],
                     cz = u[0] * w[1] - u[1] * w[0];
        m = std::min(m, std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot) * 180 / M_PI);
      }
      skinny += m < 15 ? 1 : 0;
    }
    std::printf("%6zu %7zu %8.4f %8zu %10zu %7zu %7zu\n", s.vertex_count(), s.tets.size() / 4,
                min_sj, nflat, nbdry, s.triangles.size() / 3, skinny);
    total_flat += nflat;
    total_bdry += nbdry;
    total_tets += s.tets.size() / 4;
  }
  std::printf(
      "summary: %zu of %zu tets below scaled Jacobian %.3g, %zu of them with all four "
      "vertices on the boundary\n",
      total_flat, total_tets, flat, total_bdry);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // A row per pair as it is mapped (runs on the OpenCASCADE models take minutes).
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const std::vector<std::string> args(argv + std::min(argc, 2), argv + argc);
  const std::string command = argc > 1 ? argv[1] : "";
  try {
    if (command == "pairs") return pairs(args);
    if (command == "sweep") return sweep(args);
    if (command == "cubic") return cubic(args);
    if (command == "meshes") return meshes(args);
    std::printf(
        "usage: cadinterp-mapping-report pairs|cubic|sweep|meshes [options] (--help for each)\n"
        "  pairs  quality table of the mesh mapper over random sample pairs\n"
        "  cubic  cubic builds: direct vs shared-sample neighbour transfer (§5.3)\n"
        "  sweep  VTU sequence of a built asset sweeping one parameter\n"
        "  meshes quality of a model's own meshes (flat tets, on the boundary or not)\n");
    return command.empty() || command == "--help" ? 0 : 2;
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "cadinterp-mapping-report: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cadinterp-mapping-report: %s\n", e.what());
    return 1;
  }
}
