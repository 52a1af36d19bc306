// A build session (cadinterp_builder.h, "Build sessions"): the build turned inside out. build()
// runs on a session-owned thread with an Executor whose run() publishes each wave's points as
// requests and waits for their answers, and whose simulate() (simulate_mapped, paper §6) does
// the same for one mapped mesh; whoever drives the session hands the requests to a host on any
// thread, process or rank and submits the answers in any order. The asset does not depend on the
// order: the sampler decides feasibility and reasons in row order after each wave
// (mesh_problem.h), exactly as it does for the thread pool.
//
// cadinterp_builder_run is a driver over a session too: drive_with_threads (the host on worker
// threads) or drive_on_calling_thread (cadinterp_build_options::host_on_calling_thread).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "builder/build.h"
#include "builder/sample_store.h"
#include "builder/stage_report.h"

namespace cadinterp::builder {

class BuildSession {
 public:
  /// A request as handed out: the C view, and for CADINTERP_REQUEST_SIMULATE the mesh as a
  /// Sample (what mesh::Host::simulate takes). Both point into the session.
  struct Request {
    cadinterp_build_request c{};
    const Sample* mesh = nullptr;
  };

  /// Opens the sample store of options.store_path (throws StoreError) and starts build() on the
  /// session's thread. `concurrency` is the executor's concurrency (the threads the builder's
  /// own parallel work uses). options.progress, if set, is the caller's progress callback: it is
  /// called only by report_progress(), on the caller's thread. `host` must outlive the session.
  BuildSession(const Host& host, const BuildOptions& options, int concurrency);
  /// Cancels the build if it is running and waits for its thread.
  ~BuildSession();
  BuildSession(const BuildSession&) = delete;
  BuildSession& operator=(const BuildSession&) = delete;

  /// Hands out up to `capacity` requests (cadinterp_build_session_next_requests); timeout_ms
  /// -1 waits for a request or the end, 0 does not wait. `done` as the header says.
  std::size_t next_requests(Request* out, std::size_t capacity, int timeout_ms, bool& done);
  /// The sample a request's answer is written into; nullptr when `id` is not handed out and
  /// open.
  cadinterp_sample* sample(std::uint64_t id);
  /// Answers request `id` with a finished Sample (the drivers' path: mesh::Host's result).
  /// A SAMPLE answer returns once the build has taken it (and stored it, with a store).
  cadinterp_status submit(std::uint64_t id, Sample&& answer);
  /// Answers with what was written into sample(id), validated (cadinterp_build_session_submit).
  cadinterp_status submit_written(std::uint64_t id, cadinterp_status host_status);
  /// Answers with mesh::serialize()d bytes; CADINTERP_E_INVALID_ARGUMENT (request left open)
  /// when they do not decode (cadinterp_build_session_submit_serialized).
  cadinterp_status submit_serialized(std::uint64_t id, const void* bytes, std::size_t size);
  /// Cancels (idempotent): no new request, answers dropped, the build throws BuildCancelled.
  void cancel();
  /// Calls the caller's progress callback with the build's latest progress if it changed since
  /// the last call (one call at a time); a nonzero answer cancels. Returns true when cancelled.
  bool report_progress();
  /// Waits for the build's thread, copies its report into `details` (whatever happened), then
  /// returns the result or rethrows what build() threw. Once only.
  BuildResult finish(BuildReport& details);

 private:
  class SessionExecutor;
  struct Req;

  // Request `id` moved from handed out to being answered (one answer per request), or nullptr.
  Req* claim(std::uint64_t id);
  // Gives a claimed request its answer; see submit.
  cadinterp_status answer(Req* r, Sample&& s);
  Req* publish(int kind, const double* x, const Sample* mesh);  // mu_ held
  bool run_wave(const std::vector<std::vector<double>>& points,
                const std::function<void(std::size_t, Sample&&)>& done,
                const std::function<bool()>& cancelled);
  Sample simulate(const std::vector<double>& x, const Sample& mesh);
  bool on_build_progress(const cadinterp_progress& p);
  void build_thread();

  const Host& host_;
  BuildOptions options_;  // executor, store and progress replaced by the session's
  std::function<bool(const cadinterp_progress&)> user_progress_;
  std::unique_ptr<SampleStore> store_;
  double store_seconds_ = 0;
  std::unique_ptr<SessionExecutor> exec_;

  std::mutex mu_;  // guards everything below
  std::condition_variable cv_;
  std::map<std::uint64_t, std::unique_ptr<Req>> requests_;
  std::deque<Req*> queue_;     // published, not handed out yet
  std::deque<Req*> answered_;  // SAMPLE answers the build has not taken yet
  std::uint64_t next_id_ = 1;
  bool cancelled_ = false, ended_ = false, finished_ = false;
  bool store_released_ = false;  // the build no longer uses the store (cancelled or ended)
  cadinterp_status failure_ = CADINTERP_OK;  // status of what build() threw, once ended_
  cadinterp_progress progress_{};
  std::uint64_t progress_seq_ = 0, reported_seq_ = 0;

  std::mutex progress_mu_;  // one progress call at a time
  BuildReport details_;     // written by the build's thread; read after it ends
  BuildResult result_;
  std::exception_ptr error_;
  std::thread thread_;
};

/// cadinterp_builder_run's drivers: the host's answer to each request, on `threads` worker
/// threads (progress on the calling thread), or all on the calling thread. Return when the
/// session is done; the caller then calls finish().
void drive_with_threads(BuildSession& session, const Host& host, int threads);
void drive_on_calling_thread(BuildSession& session, const Host& host);

}  // namespace cadinterp::builder
