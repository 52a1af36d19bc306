// `cadinterp build --isolate`: a build session (cadinterp_build_session_*) driven by worker
// processes (cadinterp-host-worker, host_worker_process.h), so that a host kernel that crashes,
// aborts, runs out of memory or hangs loses one sample point, not the build.
//
// Each request goes to an idle worker. A worker that dies (any signal or exit) or exceeds the
// per-sample timeout (then it is killed with SIGKILL) is replaced by a fresh one, which gets the
// same request once more. If that fails too, the point is submitted as infeasible with how the
// worker ended as its message ("host worker killed by signal 11 (Segmentation fault)", "host
// timed out after 1 s"), and the build goes on. Every request is answered exactly once: by the
// worker's sample bytes (cadinterp_build_session_submit_serialized) or by that failure.
#pragma once

#include <functional>
#include <string>

#include "cadinterp/cadinterp_builder.h"
#include "host_worker_process.h"

namespace cadinterp::tools {

struct IsolationOptions {
  WorkerSpec worker;            ///< how to start each worker
  int workers = 2;              ///< worker processes, >= 1
  double sample_timeout = 0;    ///< seconds per request and attempt; 0: no limit
  double startup_timeout = 60;  ///< seconds a worker may take to load its host
  /// Polled between requests: true stops the build (the session is cancelled).
  std::function<bool()> cancelled;
};

/// What the workers did (every count is of this run).
struct IsolationSummary {
  int workers = 0;
  int requests = 0;  ///< requests the session handed out
  int answered = 0;  ///< requests answered (a sample, or infeasible after a retry)
  int retries = 0;   ///< requests sent again to a fresh worker after a failure
  int given_up = 0;  ///< requests answered infeasible after their retry failed too
  int crashes = 0;   ///< worker failures by a signal or an unexpected exit
  int timeouts = 0;  ///< worker failures by the sample timeout
  int started = 0;   ///< worker processes started (restarts included)
};

/// The worker next to the running executable (/proc/self/exe), unless the environment variable
/// CADINTERP_HOST_WORKER names another.
std::string default_worker_executable();

/// Runs a session on `builder` with worker processes and writes the asset to `output`; `host`
/// is the builder's host as the parent loaded it (each worker must report the same name and
/// identity). The builder's progress callback runs on this thread. Returns the status of
/// cadinterp_build_session_finish, or of cadinterp_build_session_create (the builder's report
/// and error describe the run either way). Throws WorkerError when a worker cannot be
/// (re)started or loads another host; the session is destroyed first (the samples answered so
/// far stay in the store). Not thread-safe; the builder must have no session or run active.
cadinterp_status run_isolated(cadinterp_builder* builder, const std::string& output,
                              const cadinterp_host& host, const IsolationOptions& options,
                              IsolationSummary* summary);

/// "2 workers (5 started), 57 requests, 57 answered, 6 retries, 3 infeasible after a retry;
/// worker failures: 4 crashed, 2 timed out".
std::string isolation_summary_line(const IsolationSummary& s);

}  // namespace cadinterp::tools
