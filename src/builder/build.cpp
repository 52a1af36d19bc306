// The builder's pipeline (build.h), as the paper's precomputation runs: sample the host
// adaptively on the K-d tree (§4.2, mesh_problem.h), build every element from its canonical mesh
// and its terms mapped into it (§6, element_stage.h), and describe the asset around the elements
// (basis, parameters, fields, regions, provenance) for the writer.
#include "builder/build.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <thread>

#if __has_include(<unistd.h>)
#include <unistd.h>
#endif

#include "builder/calibration.h"
#include "builder/element_stage.h"
#include "builder/mesh_problem.h"
#include "builder/sample_store.h"
#include "builder/stage_report.h"
#include "cadinterp/cadinterp_version.h"
#include "core/adaptive.h"
#include "mapping/mesh_mapper.h"

namespace cadinterp::builder {

namespace {

std::string hex_double(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

}  // namespace

std::string store_fingerprint(const Host& host) {
  std::string fp = host.name() + "|" + host.identity() + "|K=" + std::to_string(host.dim());
  for (int d = 0; d < host.dim(); ++d)
    fp += "|" + host.names()[static_cast<std::size_t>(d)] + "[" +
          hex_double(host.lower()[static_cast<std::size_t>(d)]) + "," +
          hex_double(host.upper()[static_cast<std::size_t>(d)]) + "]";
  return fp;
}

std::size_t default_map_cache_bytes() {
  constexpr std::size_t least = std::size_t(512) << 20;
#if defined(_SC_PHYS_PAGES) && defined(_SC_PAGESIZE)
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) {
    const std::uint64_t quarter =
        static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page) / 4;
    return static_cast<std::size_t>(
        std::clamp<std::uint64_t>(quarter, least, std::numeric_limits<std::size_t>::max()));
  }
#endif
  return least;
}

format::WriteOptions asset_write_options(const BuildOptions& options) {
  format::WriteOptions w;
  w.position_max_abs_error = options.position_max_abs_error;
  return w;
}

const Mapper& default_mapper() {
  static const mapping::MeshMapper mesh;
  return mesh;
}

std::string options_json(const BuildOptions& o, const char* mapper_name) {
  return std::string("{\"degree\":") + std::to_string(static_cast<int>(o.degree)) +
         ",\"geometry_tolerance\":\"" + hex_double(o.geometry_tolerance) +
         "\",\"field_tolerance\":\"" + hex_double(o.field_tolerance) +
         "\",\"max_samples\":" + std::to_string(o.max_samples) +
         ",\"max_depth\":" + std::to_string(o.max_depth) + ",\"position_max_abs_error\":\"" +
         hex_double(o.position_max_abs_error) + "\",\"mapper\":\"" + mapper_name + "\"" +
         // Only a non-default transfer is recorded, so that default assets keep their bytes.
         (o.degree == core::Degree::Cubic && o.neighbour_transfer != NeighbourTransfer::Fallback
              ? std::string(",\"neighbour_transfer\":\"") +
                    (o.neighbour_transfer == NeighbourTransfer::Always ? "always" : "direct") + "\""
              : std::string()) +
         (o.simulate_mapped ? ",\"simulate_mapped\":true" : "") +
         // Likewise only a non-default bound on failed points.
         (o.infeasible_call_fraction != BuildOptions{}.infeasible_call_fraction
              ? ",\"infeasible_call_fraction\":\"" + hex_double(o.infeasible_call_fraction) + "\""
              : std::string()) +
         (o.lazy_face_centres ? ",\"lazy_face_centres\":true" : "") +
         (o.calibration_points > 0
              ? ",\"calibration_points\":" + std::to_string(o.calibration_points)
              : std::string()) +
         ",\"canonical_refinement\":" + std::to_string(o.canonical_refinement) + "}";
}

namespace {

void check_options(const Host& host, const BuildOptions& opt) {
  if (!(opt.geometry_tolerance > 0) || !(opt.field_tolerance > 0))
    throw std::invalid_argument("build: tolerances must be positive");
  if (opt.max_samples < 2) throw std::invalid_argument("build: max_samples must be at least 2");
  if (opt.max_depth < 1 || opt.max_depth >= core::kMaxLevel)
    throw std::invalid_argument("build: max_depth must be 1.." +
                                std::to_string(core::kMaxLevel - 1));
  if (opt.threads < 0) throw std::invalid_argument("build: threads must be >= 0");
  if (!(opt.position_max_abs_error >= 0))
    throw std::invalid_argument("build: position_max_abs_error must be >= 0");
  if (!std::isfinite(opt.infeasible_call_fraction))
    throw std::invalid_argument("build: infeasible_call_fraction must be finite");
  if (opt.calibration_points < 0 || opt.calibration_points > kMaxCalibrationPoints)
    throw std::invalid_argument("build: calibration_points must be 0.." +
                                std::to_string(kMaxCalibrationPoints));
  if (opt.simulate_mapped && !host.has_simulate())
    throw std::invalid_argument("build: simulate_mapped needs a host with a simulate callback");
}

// §4.2: the K-d tree refined until every element meets the tolerances (errors are relative to
// their targets, so the driver's tolerance is 1) or the sample budget is spent.
core::AdaptiveRun sample_adaptively(const Host& host, const BuildOptions& opt, MeshProblem& problem,
                                    BuildReport& details) {
  core::AdaptiveOptions ao;
  ao.degree = opt.degree;
  ao.tolerance = 1.0;  // errors are already relative to their targets
  ao.max_samples = opt.max_samples;
  ao.max_level = opt.max_depth;
  ao.max_infeasible_points =
      opt.infeasible_call_fraction < 0
          ? -1
          : static_cast<int>(std::ceil(opt.infeasible_call_fraction * opt.max_samples));
  // Lazy face centres trust an inherited split direction for any number of splits: measured on
  // the budget-bound figures, a limit of 2 re-probes enough directions to cost 2.3 calls per
  // sample on the plate and a larger field error (src/core/README.md).
  ao.lazy_face_centres = opt.lazy_face_centres;
  if (opt.lazy_face_centres) ao.inherited_direction_splits = std::numeric_limits<int>::max();
  const StageTimer refining(details.refinement_seconds, &details.sampling_seconds);
  core::AdaptiveRun run = core::adaptive_run(host.dim(), host.lower(), host.upper(), problem, ao);
  details.infeasible_splits = run.infeasible_splits;
  details.interior_unsplit = run.interior_unsplit;
  details.bound_unsplit = run.bound_unsplit;
  return run;
}

// Per basis sample: whether the host failed there (the compiled basis marks the elements that
// depend on it). Throws BuildInfeasible when it failed at every sample; else appends every
// failed row to out.infeasible, in row order.
std::vector<bool> host_failures(const core::AdaptiveRun& run, const MeshProblem& problem,
                                const BuildReport& details, BuildResult& out) {
  const int S = run.basis.sample_count();
  std::vector<bool> infeasible_sample(static_cast<std::size_t>(S));
  bool any = false;
  for (int k = 0; k < S; ++k) {
    const bool ok =
        run.row_feasible[static_cast<std::size_t>(run.sample_row[static_cast<std::size_t>(k)])] !=
        0;
    infeasible_sample[static_cast<std::size_t>(k)] = !ok;
    any = any || ok;
  }
  if (!any)
    throw BuildInfeasible(
        "the host failed at every sample point (" +
        std::to_string(details.counts.infeasible_points) + " points: " +
        reasons_text(details.infeasible_reasons, details.other_infeasible_points) + ")");
  for (int r = 0; r < problem.rows(); ++r)
    if (!problem.sample(r).feasible)
      out.infeasible.push_back({problem.point(r), problem.sample(r).message});
  return infeasible_sample;
}

[[noreturn]] void throw_no_element(std::size_t elements, const BuildReport& details) {
  std::string why = "no element could be built (all " + std::to_string(elements) + " infeasible)";
  if (!details.element_reasons.empty())
    why +=
        "; elements: " + reasons_text(details.element_reasons, details.other_infeasible_elements);
  if (!details.infeasible_reasons.empty())
    why += "; points: " + reasons_text(details.infeasible_reasons, details.other_infeasible_points);
  throw BuildInfeasible(why);
}

// What the asset holds beside its elements: the basis with the refused elements marked
// infeasible, the parameters, the fields and regions (those of `field_source`, which every
// feasible sample shares), the provenance, and the host's failures.
void describe_asset(const Host& host, const BuildOptions& opt, const Mapper& mapper,
                    const core::CompiledBasis& cb, const std::vector<std::uint8_t>& element_ok,
                    const Sample& field_source, BuildResult& out) {
  format::AssetContent& c = out.content;
  core::CompiledBasis::Parts parts = cb.parts();
  for (std::size_t e = 0; e < element_ok.size(); ++e)
    parts.elem_feasible[e] = static_cast<std::uint8_t>(parts.elem_feasible[e] && element_ok[e]);
  out.basis =
      std::make_unique<core::CompiledBasis>(core::CompiledBasis::from_parts(std::move(parts)));
  c.basis = out.basis.get();
  for (int d = 0; d < host.dim(); ++d)
    c.parameters.push_back(
        {host.names()[static_cast<std::size_t>(d)], host.units()[static_cast<std::size_t>(d)],
         host.lower()[static_cast<std::size_t>(d)], host.upper()[static_cast<std::size_t>(d)]});
  for (const Field& f : field_source.fields)
    c.fields.push_back(
        {f.name, f.location == 0 ? format::FieldLocation::Vertex : format::FieldLocation::Tet,
         f.components, f.unit});
  for (const Region& r : field_source.regions) c.regions.push_back({r.name, r.kind, r.face_tags});
  c.builder_version = std::to_string(CADINTERP_VERSION_MAJOR) + "." +
                      std::to_string(CADINTERP_VERSION_MINOR) + "." +
                      std::to_string(CADINTERP_VERSION_PATCH);
  c.host = host.name();
  c.options_json = options_json(opt, mapper.name());
  for (const InfeasiblePoint& f : out.infeasible) c.infeasible.push_back({f.x, f.message});
}

// The scalar outputs (those of `field_source`, which every feasible sample shares by name and
// order): per basis sample its host's value, NaN where the host failed (no feasible element
// uses such a sample).
void sample_outputs(const core::AdaptiveRun& run, const MeshProblem& problem,
                    const Sample& field_source, format::AssetContent& c) {
  const int S = run.basis.sample_count();
  for (std::size_t o = 0; o < field_source.outputs.size(); ++o) {
    format::OutputInfo info;
    info.name = field_source.outputs[o].name;
    info.unit = field_source.outputs[o].unit;
    info.values.assign(static_cast<std::size_t>(S), std::numeric_limits<double>::quiet_NaN());
    for (int k = 0; k < S; ++k) {
      const Sample& s = problem.sample(run.sample_row[static_cast<std::size_t>(k)]);
      if (s.feasible && o < s.outputs.size())
        info.values[static_cast<std::size_t>(k)] = s.outputs[o].value;
    }
    c.outputs.push_back(std::move(info));
  }
}

BuildResult build_stages(const Host& host, const BuildOptions& opt, BuildReport& details,
                         Clock::time_point start) {
  check_options(host, opt);
  BuildResult out;
  cadinterp_build_report& rep = details.counts;
  const Mapper& mapper = opt.mapper ? *opt.mapper : default_mapper();
  const int threads = opt.threads > 0
                          ? opt.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  ThreadPoolExecutor pool(host, threads);
  Executor& exec = opt.executor ? *opt.executor : pool;

  std::unique_ptr<SampleStore> own_store;
  SampleStore* store = opt.store;
  if (!store && !opt.store_path.empty()) {
    const StageTimer timer(details.store_seconds);
    own_store = std::make_unique<SampleStore>(opt.store_path, store_fingerprint(host));
    store = own_store.get();
  }

  // Sample adaptively (§4.2): the rows and maps of `problem` outlive the refinement, since the
  // element stage reads them.
  MeshProblem problem(host, opt, mapper, exec, store, details, start);
  const core::AdaptiveRun run = sample_adaptively(host, opt, problem, details);
  const StageTimer elements_timer(details.elements_seconds);
  const std::vector<int> leaves = run.basis.tree().leaves();
  rep.samples = run.basis.sample_count();
  rep.elements = static_cast<int>(leaves.size());
  const std::vector<bool> infeasible_sample = host_failures(run, problem, details, out);
  core::CompiledBasis cb =
      core::CompiledBasis::compile(run.basis, host.lower(), host.upper(), &infeasible_sample);

  // Map per element (§6): its canonical mesh and its terms in that mesh's combinatorics.
  // Calibration's held-out points (calibration.h) are asked first, so that each element measures
  // them on the meshes it stores.
  HeldOutPoints held_out = ask_held_out_points(opt, problem, cb, details);
  std::vector<std::uint8_t> element_ok(leaves.size(), 1);
  const Sample* field_source =
      map_elements(host, opt, exec, problem, run, cb, infeasible_sample, leaves, details, out,
                   element_ok, held_out.x.empty() ? nullptr : &held_out);
  if (!field_source) throw_no_element(leaves.size(), details);
  calibrate_error_models(opt, cb, held_out, out.content.elements, details);

  // The asset around its elements.
  describe_asset(host, opt, mapper, cb, element_ok, *field_source, out);
  sample_outputs(run, problem, *field_source, out.content);
  rep.budget_exhausted = run.budget_exhausted ? 1 : 0;
  return out;
}

}  // namespace

BuildResult build(const Host& host, const BuildOptions& opt, BuildReport* report) {
  const auto start = Clock::now();
  BuildReport local;
  BuildReport& details = report ? *report : local;
  details = BuildReport{};
  // Whatever ends the build, the report says how far it got: every stage writes its counts
  // into `details` as it goes, and only the wall time and the failure are added here.
  try {
    BuildResult out = build_stages(host, opt, details, start);
    details.counts.wall_seconds = seconds_since(start);
    out.report = details.counts;
    out.details = details;
    return out;
  } catch (const std::exception& e) {
    details.counts.wall_seconds = seconds_since(start);
    details.failure = e.what();
    throw;
  } catch (...) {
    details.counts.wall_seconds = seconds_since(start);
    details.failure = "unknown exception";
    throw;
  }
}

}  // namespace cadinterp::builder
