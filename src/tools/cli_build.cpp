// `cadinterp build`: loads a host (a library by dlopen, or one linked in), runs the builder on it
// with progress on stderr and a clean stop on Ctrl-C, and prints the build's summary. CMake
// compiles this file only when libcadinterp_builder is part of the build;
// cli_build_unavailable.cpp stands in otherwise.
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "host_library.h"
#include "isolated_driver.h"

#ifdef CADINTERP_CLI_HAVE_ANALYTIC
#include "analytic_host.h"
#endif
#ifdef CADINTERP_CLI_HAVE_MPI
#include "mpi_driver.h"
#endif

namespace cadinterp::cli {

const char* builder_availability() { return "yes"; }

std::string builtin_hosts() {
  std::string s;
#ifdef CADINTERP_CLI_HAVE_ANALYTIC
  s += "analytic";
#endif
  return s;
}

namespace {

volatile std::sig_atomic_t g_cancel = 0;

extern "C" void on_sigint(int) { g_cancel = 1; }

struct ProgressState {
  bool tty = false;
  bool quiet = false;
  double last_print = -1e9;
  bool line_open = false;  // a \r-updated line is on the terminal
};

std::string progress_line(const cadinterp_progress& p, bool bar) {
  const int total = p.samples_done + p.samples_queued;
  std::string s;
  if (bar) {
    constexpr int kWidth = 24;
    const int filled = total > 0 ? kWidth * p.samples_done / total : 0;
    s = "[" + std::string(static_cast<std::size_t>(filled), '#') +
        std::string(static_cast<std::size_t>(kWidth - filled), '.') + "] ";
  }
  s += fmt("%d/%d samples, %d elements, %s", p.samples_done, total, p.elements,
           human_seconds(p.seconds).c_str());
  if (p.eta_seconds >= 0) s += ", ETA " + human_seconds(p.eta_seconds);
  if (g_cancel) s += " (cancelling)";
  return s;
}

extern "C" int on_progress(void* user, const cadinterp_progress* p) {
  auto* st = static_cast<ProgressState*>(user);
  if (!st->quiet) {
    // A terminal gets a redrawn bar at most 10 times a second; a log gets a line a second.
    const double interval = st->tty ? 0.1 : 1.0;
    if (p->seconds - st->last_print >= interval) {
      st->last_print = p->seconds;
      if (st->tty) {
        std::fprintf(stderr, "\r%s\x1b[K", progress_line(*p, true).c_str());
        st->line_open = true;
      } else {
        std::fprintf(stderr, "progress: %s\n", progress_line(*p, false).c_str());
      }
      std::fflush(stderr);
    }
  }
  return g_cancel ? 1 : 0;
}

// A built-in host by name, or a host library by path (host_library.h).
struct LoadedHost {
  tools::HostLibrary library;
  const cadinterp_host* host = nullptr;
  std::string source;  // for messages: the library's path or "built-in ... host"
};

void load_host(const std::string& spec, const std::string& model, const std::string& options,
               LoadedHost& out) {
  try {
    if (tools::looks_like_library_path(spec)) {
      out.host = out.library.load(spec, model, options);
      out.source = spec;
      return;
    }
#ifdef CADINTERP_CLI_HAVE_ANALYTIC
    if (spec == "analytic") {
      out.host =
          tools::host_from_entry(&cadinterp_host_entry, "built-in analytic host", model, options);
      return;
    }
#endif
  } catch (const tools::HostLoadError& e) {
    throw RuntimeFailure(describe(e.status, e.what()));
  }
  const std::string hosts = builtin_hosts();
  throw UsageError("unknown host '" + spec +
                   "': give the path of a host library (.so) or a built-in host (" +
                   (hosts.empty() ? "none in this build" : hosts) + ")");
}

struct BuilderDestroyer {
  void operator()(cadinterp_builder* b) const { cadinterp_builder_destroy(b); }
};

struct BuildArgs {
  cadinterp_build_options o;
  std::string host_spec, model, host_options, store, output, degree;
  bool quiet = false, simulate_mapped = false, calling_thread = false, lazy_faces = false;
  bool mpi = false;  // --mpi (the MPI block below)
  // --isolate (isolated_driver.h)
  bool isolate = false;
  double sample_timeout = 0;
  int worker_memory = 0;
  int map_cache_mb = 0;  // --map-cache (0: the builder's default)
};

void declare_options(ArgParser& p, BuildArgs& a) {
  cadinterp_build_options& o = a.o;
  const std::string hosts = builtin_hosts();
  p.option("host", 0, "PATH|NAME",
           "host library (.so exporting " CADINTERP_HOST_ENTRY_NAME ")\nor built-in host (" +
               (hosts.empty() ? std::string("none in this build") : hosts) + ")",
           &a.host_spec)
      .required();
  p.option("model", 'm', "NAME", "model of the host (default: the host's default model)", &a.model);
  p.option("host-options", 0, "K=V,...", "host settings, passed through to the host",
           &a.host_options);
  p.choice("degree", 0, "basis degree: 1 linear (C0), 3 cubic (C2)", {"1", "3"}, &a.degree);
  p.option("geometry-tol", 0, "REL", "Hausdorff error target / bbox diagonal",
           &o.geometry_tolerance, 1e-12, 1);
  p.option("field-tol", 0, "REL", "field error target / the field's value range",
           &o.field_tolerance, 1e-12, 1e6);
  p.option("max-samples", 0, "N", "no refinement starts beyond this many samples", &o.max_samples,
           1, 100000000);
  p.option("max-depth", 0, "N", "splits per direction", &o.max_depth, 0, 30);
  p.option("threads", 'j', "N", "host evaluations in parallel (0: all cores)", &o.threads, 0, 4096);
  p.flag("calling-thread", 0,
         "call the host only from the main thread, one evaluation at a time\n(kernels bound to "
         "the thread that created them; --threads is ignored)",
         &a.calling_thread);
  p.option("store", 0, "FILE", "sample store (SQLite) to resume from and save to", &a.store);
  p.option("lossy-positions", 0, "ERR",
           "max absolute error the codec may add to positions,\nin model units (0: lossless)",
           &o.position_max_abs_error, 0, 1e300);
  p.flag("simulate-mapped", 0,
         "a sample mapped onto another's mesh gets the host's simulate\non the mapped mesh "
         "instead of its own fields carried over",
         &a.simulate_mapped);
  p.option("canonical-refinement", 0, "N",
           "rounds of canonical refinement where a mapped term departs\nfrom its own boundary "
           "(0: none)",
           &o.canonical_refinement, 0, 20);
  p.option("infeasible-calls", 0, "FRAC",
           "failed points allowed for refining toward the region where the\nhost fails, as a "
           "fraction of --max-samples (negative: no bound;\n0: elements with a failed point "
           "are never split)",
           &o.infeasible_call_fraction, -1, 1e6);
  p.flag("lazy-face-centres", 0,
         "for budget-bound builds: test an element's face centres only once\nit passes at "
         "those already answered (fewer host calls per sample)",
         &a.lazy_faces);
  p.option("map-cache", 0, "MB",
           "memory for mapped samples kept from the refinement for the\nelement stage, in MiB "
           "(less: the same asset, mapped again)",
           &a.map_cache_mb, 0, 1 << 30)
      .show_default("a quarter of physical memory, at least 512");
  p.option("calibration-points", 0, "N",
           "random points where the host is asked besides the samples, to\ncalibrate "
           "the error estimates on points no element is built from\n(0: none)",
           &o.calibration_points, 0, CADINTERP_MAX_CALIBRATION_POINTS);
  p.option("output", 'o', "OUT.cadi", "the asset to write", &a.output).required();
  p.flag("quiet", 'q', "no progress output (the summary is still printed)", &a.quiet);
  // --mpi: the MPI block below.
  p.flag(
      "mpi", 0,
      "distributed build under mpirun (at least 2 ranks): rank 0 runs\nthe builder and the "
      "store, ranks 1.. run the host; each rank\nloads --host itself (docs/distributed-builds.md)",
      &a.mpi);
  // Crash isolation: host calls in worker processes (isolated_driver.h).
  p.flag("isolate", 0,
         "run every host call in a worker process (cadinterp-host-worker):\na crash, abort, "
         "out-of-memory death or timeout is retried once\nin a fresh worker, then makes that "
         "point infeasible;\n--threads workers (0: 2)",
         &a.isolate);
  p.option("sample-timeout", 0, "S",
           "with --isolate: seconds one host call may take before its\nworker is killed",
           &a.sample_timeout, 1e-3, 1e9)
      .show_default("no limit");
  p.option("worker-memory", 0, "MB", "with --isolate: address-space limit of each worker, in MiB",
           &a.worker_memory, 16, 1 << 30)
      .show_default("none");
  p.epilog("A host library is loaded with dlopen; its function " CADINTERP_HOST_ENTRY_NAME
           "(model, options, &error)\nreturns the host (cadinterp_host_entry_fn in "
           "cadinterp_builder.h).\n"
           "\nexamples:\n"
           "  cadinterp build --host analytic -o demo.cadi\n"
           "  cadinterp build --host ./libmyhost.so --model bracket --degree 3 \\\n"
           "      --geometry-tol 1e-3 --max-samples 500 --store bracket.db -o bracket.cadi\n"
           "  cadinterp build --host ./libmyhost.so --isolate --sample-timeout 600 \\\n"
           "      --worker-memory 8000 -j 4 --store bracket.db -o bracket.cadi\n"
           "  mpirun -np 8 cadinterp build --mpi --host ./libmyhost.so --store b.db -o b.cadi");
}

/// Runs the build (`run`, returning its status); the wall time goes to `*wall`.
template <typename Run>
cadinterp_status run_cancellable(Run run, double* wall) {
  // SA_RESETHAND: the first Ctrl-C asks for a clean stop, a second one kills as usual.
  struct sigaction sa {
  }, old{};
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &sa, &old);
  const auto t0 = Clock::now();
  const cadinterp_status s = run();
  *wall = seconds_since(t0);
  sigaction(SIGINT, &old, nullptr);
  return s;
}

/// What the run did, also when it failed (cadinterp_builder_report covers every exit path).
void print_summary(std::FILE* out, cadinterp_builder* builder, const cadinterp_build_report& r,
                   const cadinterp_build_stages& st, bool simulate_mapped) {
  std::fprintf(out,
               "  samples            %d (points requested %d, host evaluations %d, from the "
               "store %d, infeasible %d)\n",
               r.samples, st.points_requested, r.host_evaluations, r.store_hits,
               r.infeasible_points);
  for (int i = 0; i < st.infeasible_reasons; ++i) {
    const char* message = nullptr;
    int count = 0;
    if (cadinterp_builder_infeasible_reason(builder, i, &message, &count) == CADINTERP_OK)
      std::fprintf(out, "    infeasible x%-5d %s\n", count, message);
  }
  if (st.other_infeasible_points > 0)
    std::fprintf(out, "    infeasible x%-5d (other messages)\n", st.other_infeasible_points);
  std::fprintf(out, "  elements           %d (infeasible %d, of which unmapped %d)\n", r.elements,
               r.infeasible_elements, st.unmapped_elements);
  if (st.unmapped_fallbacks > 0)
    std::fprintf(out,
                 "  corner fallback    %d cubic elements multilinear on their corners: a term "
                 "could not be mapped\n",
                 st.unmapped_fallbacks);
  if (st.calibration_count > 0) {
    std::fprintf(out, "  calibration        %d points; error model factors", st.calibrated_points);
    for (int q = 0; q < st.calibration_count; ++q) std::fprintf(out, " %.3g", st.calibration[q]);
    std::fprintf(out, ", floors added");
    for (int q = 0; q < st.calibration_count; ++q)
      std::fprintf(out, " %.3g", st.calibration_floors[q]);
    std::fprintf(out, " (geometry, then each field)\n");
  }
  if (r.infeasible_points > 0)
    std::fprintf(out,
                 "  infeasible region  %d failed host evaluations; %d splits toward the boundary, "
                 "%d elements inside it left whole, %d left at the bound\n",
                 r.infeasible_host_evaluations, st.infeasible_splits, st.interior_unsplit,
                 st.bound_unsplit);
  if (simulate_mapped)
    std::fprintf(out,
                 "  simulate mapped    %d mapped terms simulated on their mapped mesh, %d "
                 "failed (their fields carried over)\n",
                 st.mapped_simulated, st.mapped_simulate_failures);
  if (st.mapped_simulate_failures > 0)
    std::fprintf(out, "    first failure    %s\n", st.first_mapped_simulate_failure);
  if (st.refined_elements > 0)
    std::fprintf(out, "  refined canonical  %d elements, %d vertices added\n", st.refined_elements,
                 st.refined_vertices);
  if (st.maps > 0)
    std::fprintf(out, "  maps               %d (%d again after the cache dropped them)\n", st.maps,
                 st.maps_again);
  std::fprintf(out,
               "  stages             store %s, sampling %s, refinement %s, elements %s, "
               "writing %s\n",
               human_seconds(st.store_seconds).c_str(), human_seconds(st.sampling_seconds).c_str(),
               human_seconds(st.refinement_seconds).c_str(),
               human_seconds(st.elements_seconds).c_str(), human_seconds(st.write_seconds).c_str());
}

/// Cancellation and failure become a RuntimeFailure (with the summary on stderr for a failure);
/// success prints the summary on stdout.
void report_outcome(cadinterp_status s, double wall, cadinterp_builder* builder, const BuildArgs& a,
                    const ProgressState& progress) {
  cadinterp_build_report r{};
  r.struct_size = sizeof r;
  cadinterp_builder_report(builder, &r);
  if (s == CADINTERP_E_CANCELLED) {
    throw RuntimeFailure(describe(
        s, fmt("stopped after %s; %s", human_seconds(wall).c_str(),
               a.store.empty() ? "the samples were in memory only (use --store to resume later)"
                               : ("finished samples are kept in " + a.store +
                                  ": run the same command to resume")
                                     .c_str())));
  }
  cadinterp_build_stages st;
  std::memset(&st, 0, sizeof st);
  st.struct_size = sizeof st;
  cadinterp_builder_stages(builder, &st);
  const bool simulate_mapped = a.o.simulate_mapped != 0;
  if (s != CADINTERP_OK) {
    std::fprintf(stderr, "build summary (failed after %s)\n", human_seconds(wall).c_str());
    print_summary(stderr, builder, r, st, simulate_mapped);
    throw RuntimeFailure("build failed: " + describe(s, cadinterp_builder_error(builder)));
  }
  if (!a.quiet)
    std::fprintf(stderr, "%sdone: %d samples, %d elements in %s\n",
                 progress.tty ? "" : "progress: ", r.samples, r.elements,
                 human_seconds(r.wall_seconds).c_str());

  std::printf("build summary\n");
  std::printf("  asset              %s, %s (%llu bytes)\n", a.output.c_str(),
              human_bytes(r.asset_bytes).c_str(), static_cast<unsigned long long>(r.asset_bytes));
  print_summary(stdout, builder, r, st, simulate_mapped);
  std::printf("  stored meshes      %d\n", r.stored_meshes);
  std::printf("  max error          %.3g x the target (%s)\n", r.max_error,
              r.max_error <= 1 ? "met" : "not met");
  std::printf("  time               %s wall, %s in the host", human_seconds(r.wall_seconds).c_str(),
              human_seconds(r.host_seconds).c_str());
  if (r.host_evaluations > 0)
    std::printf(", %s per sample", human_seconds(r.host_seconds / r.host_evaluations).c_str());
  std::printf("\n");
  if (r.budget_exhausted)
    std::printf(
        "note: --max-samples (%d) stopped refinement before every element met the tolerance\n",
        a.o.max_samples);
}

// ---- --mpi: distributed builds (mpi_driver.h) ----------------------------------------------
#ifdef CADINTERP_CLI_HAVE_MPI
volatile std::sig_atomic_t g_mpi_stop = 0;

// mpirun sends SIGTERM to every rank when one dies or on Ctrl-C: rank 0 then cancels cleanly
// (its accepted samples are in the store) instead of dying mid-write.
extern "C" void on_mpi_stop(int signal) {
  g_mpi_stop = signal;
  g_cancel = 1;
}

/// MPI_Init (only under --mpi, so the tool without mpirun never touches MPI) and the check that
/// there is a rank to run the host besides rank 0.
std::unique_ptr<tools::mpi::World> start_mpi() {
  std::unique_ptr<tools::mpi::World> world;
  try {
    world = std::make_unique<tools::mpi::World>();
  } catch (const std::runtime_error& e) {
    throw RuntimeFailure(std::string("--mpi: ") + e.what());
  }
  if (world->size() < 2)
    throw UsageError(
        "--mpi needs at least 2 ranks: rank 0 runs the builder and ranks 1.. run the host "
        "(mpirun -np N cadinterp build --mpi ..., N >= 2); without mpirun, drop --mpi");
  return world;
}

/// Ranks >= 1: load the host as rank 0 does, then answer its requests until it says stop.
int serve_rank(const tools::mpi::World& world, const BuildArgs& a) {
  LoadedHost host;
  std::string error;
  try {
    load_host(a.host_spec, a.model, a.host_options, host);
  } catch (const std::exception& e) {
    error = e.what();
  }
  try {
    tools::mpi::serve(world, host.host, error);
  } catch (const std::runtime_error& e) {
    throw RuntimeFailure(fmt("--mpi rank %d: %s", world.rank(), e.what()));
  }
  return error.empty() ? kExitOk : kExitError;
}

/// Rank 0: the build driven over the ranks; SIGTERM and SIGINT stop it cleanly.
cadinterp_status run_mpi(tools::mpi::World& world, cadinterp_builder* builder,
                         const cadinterp_host* host, const std::string& output,
                         tools::mpi::DriveResult* result) {
  struct sigaction sa {
  }, old_term{}, old_int{};
  sa.sa_handler = on_mpi_stop;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGTERM, &sa, &old_term);
  sigaction(SIGINT, &sa, &old_int);
  try {
    *result = tools::mpi::drive(world, builder, host, output, &g_mpi_stop);
  } catch (const std::runtime_error& e) {
    throw RuntimeFailure(std::string("--mpi: ") + e.what());
  }
  sigaction(SIGTERM, &old_term, nullptr);
  sigaction(SIGINT, &old_int, nullptr);
  // The other ranks may be dead already: finalizing would wait for them.
  if (result->stop_signal != 0) world.abandon();
  return result->status;
}

/// rank 0's load: CPU time of every thread of rank 0 (builder, store, MPI) per answer received
/// (a sample, or with --simulate-mapped also a simulation on a mapped mesh), and its share of the
/// wall time (busy = overhead x throughput, docs/distributed-builds.md).
void print_mpi_summary(const tools::mpi::DriveResult& r) {
  std::printf(
      "  mpi                %d host ranks, %d answers from them, %.2f answers/s; rank 0 "
      "CPU %.3f s (%.2f ms per answer, %.1f %% busy)\n",
      r.worker_ranks, r.answers_received,
      r.wall_seconds > 0 ? r.answers_received / r.wall_seconds : 0.0, r.cpu_seconds,
      r.answers_received > 0 ? 1e3 * r.cpu_seconds / r.answers_received : 0.0,
      r.wall_seconds > 0 ? 100 * r.cpu_seconds / r.wall_seconds : 0.0);
}
#endif
/// --isolate's options need it, and a host library: a worker loads the host by its path.
void check_isolation_args(const ArgParser& p, const BuildArgs& a) {
  if (!a.isolate && (p.seen("sample-timeout") || p.seen("worker-memory")))
    throw UsageError("--sample-timeout and --worker-memory need --isolate");
  if (a.isolate && a.mpi)
    throw UsageError(
        "--isolate runs the host in worker processes, --mpi on other ranks: give one of them");
  if (a.isolate && a.calling_thread)
    throw UsageError(
        "--isolate calls the host in worker processes, --calling-thread on this "
        "thread: give one of them");
  if (a.isolate && !tools::looks_like_library_path(a.host_spec))
    throw UsageError(
        "--isolate runs the host in worker processes, which load it from a library: "
        "give --host the path of a host library (the built-in '" +
        a.host_spec +
        "' host has none; the analytic one is "
        "libcadinterp_host_analytic.so)");
}

/// The build through worker processes; `*line` gets the isolation summary.
cadinterp_status run_isolated_build(cadinterp_builder* builder, const cadinterp_host& host,
                                    const BuildArgs& a, std::string* line) {
  tools::IsolationOptions io;
  io.worker.executable = tools::default_worker_executable();
  io.worker.library = a.host_spec;
  io.worker.model = a.model;
  io.worker.options = a.host_options;
  io.worker.memory_mb = a.worker_memory;
  io.workers = a.o.threads > 0 ? a.o.threads : 2;
  io.sample_timeout = a.sample_timeout;
  io.cancelled = [] { return g_cancel != 0; };
  tools::IsolationSummary summary;
  try {
    const cadinterp_status s = tools::run_isolated(builder, a.output, host, io, &summary);
    *line = tools::isolation_summary_line(summary);
    return s;
  } catch (const tools::WorkerError& e) {
    throw RuntimeFailure(describe(CADINTERP_E_IO, e.what()));
  }
}

}  // namespace

int cmd_build(const std::vector<std::string>& args) {
  BuildArgs a;
  cadinterp_build_options& o = a.o;
  cadinterp_build_options_init(&o);
  a.degree = std::to_string(o.degree);
  ArgParser p(
      "cadinterp build", "--host PATH|NAME -o OUT.cadi [options]",
      "Precomputes a parametric model into an asset: samples the host adaptively on a K-d tree\n"
      "until every element meets the tolerances or a budget is reached, then writes the asset.\n"
      "Ctrl-C cancels cleanly; with --store, running the same command again resumes without\n"
      "evaluating finished samples again.");
  declare_options(p, a);
  if (!p.parse(args)) return kExitOk;
#ifdef CADINTERP_CLI_HAVE_MPI
  std::unique_ptr<tools::mpi::World> world;
  if (a.mpi) {
    world = start_mpi();
    if (world->rank() != 0) return serve_rank(*world, a);
  }
#else
  if (a.mpi)
    throw UsageError(
        "--mpi: this build has no MPI support (configure with MPI found, "
        "CADINTERP_WITH_MPI=ON; Debian: libopenmpi-dev)");
#endif
  o.degree = std::stoi(a.degree);
  o.simulate_mapped = a.simulate_mapped ? 1 : 0;
  o.host_on_calling_thread = a.calling_thread ? 1 : 0;
  o.lazy_face_centres = a.lazy_faces ? 1 : 0;
  o.map_cache_bytes = static_cast<std::uint64_t>(a.map_cache_mb) << 20;
  if (!a.store.empty()) o.store_path = a.store.c_str();

  LoadedHost host;
  check_isolation_args(p, a);
  load_host(a.host_spec, a.model, a.host_options, host);

  ProgressState progress;
  progress.tty = isatty(STDERR_FILENO) != 0;
  progress.quiet = a.quiet;
  o.progress = on_progress;
  o.progress_user = &progress;

  cadinterp_builder* raw = nullptr;
  cadinterp_status s = cadinterp_builder_create(host.host, &o, &raw);
  if (s != CADINTERP_OK)
    throw RuntimeFailure("cannot create the builder: " +
                         describe(s, cadinterp_builder_create_error()));
  std::unique_ptr<cadinterp_builder, BuilderDestroyer> builder(raw);

  if (!a.quiet) {
    std::fprintf(stderr, "building %s with %s (%d parameter%s, degree %d)%s\n", a.output.c_str(),
                 host.source.c_str(), host.host->parameter_count,
                 host.host->parameter_count == 1 ? "" : "s", o.degree,
                 a.store.empty() ? "" : (", store " + a.store).c_str());
  }
  double wall = 0;
  std::string isolation;
#ifdef CADINTERP_CLI_HAVE_MPI
  tools::mpi::DriveResult mpi_result;
  if (world) {
    s = run_mpi(*world, builder.get(), host.host, a.output, &mpi_result);
    wall = mpi_result.wall_seconds;
  } else
#endif
      if (a.isolate) {
    s = run_cancellable(
        [&] { return run_isolated_build(builder.get(), *host.host, a, &isolation); }, &wall);
  } else {
    s = run_cancellable([&] { return cadinterp_builder_run(builder.get(), a.output.c_str()); },
                        &wall);
  }
  // The bar's last frame may be up to 0.1 s stale: replace it by the outcome below.
  if (progress.line_open) std::fputs("\r\x1b[K", stderr);
  if (a.isolate && s != CADINTERP_OK) std::fprintf(stderr, "isolation: %s\n", isolation.c_str());
  report_outcome(s, wall, builder.get(), a, progress);
#ifdef CADINTERP_CLI_HAVE_MPI
  if (world) print_mpi_summary(mpi_result);
#endif
  if (a.isolate) std::printf("  isolation          %s\n", isolation.c_str());
  return kExitOk;
}

}  // namespace cadinterp::cli
