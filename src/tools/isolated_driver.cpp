#include "isolated_driver.h"

#include <limits.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

namespace cadinterp::tools {

namespace {

using Clock = std::chrono::steady_clock;

// Longest poll while requests run, so that a cancel is seen even when every worker is stuck in
// a host without a timeout.
constexpr int kMaxPollMs = 250;

struct Job {
  std::uint64_t id = 0;
  std::vector<double> x;
  const cadinterp_host_mesh* mesh = nullptr;  // session-owned, valid until submitted
  int attempt = 1;
  std::string first_failure;
};

struct Slot {
  std::unique_ptr<HostWorker> worker;
  std::optional<Job> job;
  Clock::time_point deadline;
};

std::string seconds_text(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", s);
  return b;
}

class Driver {
 public:
  Driver(cadinterp_build_session* session, const cadinterp_host& host,
         const IsolationOptions& options, IsolationSummary& summary)
      : session_(session), host_(host), options_(options), summary_(summary) {
    slots_.resize(static_cast<std::size_t>(std::max(1, options.workers)));
    summary_.workers = static_cast<int>(slots_.size());
    for (Slot& slot : slots_) start(slot);
  }

  // Until the session is done: hands requests to idle workers and collects their answers.
  // Throws WorkerError when a worker cannot be (re)started.
  void run() {
    int done = 0;
    for (;;) {
      // Also when every worker is stuck in a host without a timeout: the session is cancelled
      // and the workers are stopped at once.
      if (options_.cancelled && options_.cancelled()) {
        cadinterp_build_session_cancel(session_);
        return;
      }
      std::size_t idle = 0;
      for (const Slot& slot : slots_) idle += slot.job ? 0 : 1;
      const bool busy = idle < slots_.size();
      if (!done && pending_.size() < idle) take_requests(idle - pending_.size(), busy, &done);
      // Done with requests still out only when the session failed or was cancelled: their
      // answers would be dropped, so the workers are stopped instead.
      if (done) return;
      for (Slot& slot : slots_) {
        if (pending_.empty()) break;
        if (slot.job) continue;
        Job job = std::move(pending_.front());
        pending_.pop_front();
        dispatch(slot, std::move(job));
      }
      if (std::any_of(slots_.begin(), slots_.end(), [](const Slot& s) { return s.job; })) collect();
    }
  }

 private:
  void start(Slot& slot) {
    slot.worker.reset();
    slot.worker = std::make_unique<HostWorker>(options_.worker, options_.startup_timeout);
    ++summary_.started;
    const std::string identity = host_.identity ? host_.identity : "";
    if (slot.worker->host_name() != host_.name || slot.worker->host_identity() != identity)
      throw WorkerError("the host worker loaded '" + slot.worker->host_name() + "' (" +
                        slot.worker->host_identity() + "), not the build's host '" + host_.name +
                        "' (" + identity + ")");
  }

  void take_requests(std::size_t capacity, bool busy, int* done) {
    std::vector<cadinterp_build_request> requests(capacity);
    std::size_t n = 0;
    // With requests out, only what is ready now; else wait a little for the next wave.
    cadinterp_build_session_next_requests(session_, requests.data(), capacity,
                                          busy ? 0 : kMaxPollMs, &n, done);
    for (std::size_t i = 0; i < n; ++i) {
      const cadinterp_build_request& r = requests[i];
      Job job;
      job.id = r.id;
      job.x.assign(r.x, r.x + r.parameter_count);
      job.mesh = r.kind == CADINTERP_REQUEST_SIMULATE ? r.mesh : nullptr;
      pending_.push_back(std::move(job));
      ++summary_.requests;
    }
  }

  void dispatch(Slot& slot, Job job) {
    slot.job = std::move(job);
    if (options_.sample_timeout > 0)
      slot.deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(options_.sample_timeout));
    if (!slot.worker->send(slot.job->x, slot.job->mesh))
      fail(slot, "host worker " + slot.worker->kill_and_reap(), false);
  }

  // Waits for answers or deadlines (at most kMaxPollMs) and handles what came.
  void collect() {
    std::vector<pollfd> fds;
    std::vector<Slot*> polled;
    int timeout = kMaxPollMs;
    const auto now = Clock::now();
    for (Slot& slot : slots_) {
      if (!slot.job) continue;
      fds.push_back(pollfd{slot.worker->fd(), POLLIN, 0});
      polled.push_back(&slot);
      if (options_.sample_timeout > 0) {
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(slot.deadline - now).count();
        timeout = std::min(timeout, static_cast<int>(std::max<long long>(0, left)));
      }
    }
    poll(fds.data(), fds.size(), timeout);
    for (std::size_t i = 0; i < polled.size(); ++i) {
      Slot& slot = *polled[i];
      const bool timed_out = options_.sample_timeout > 0 && Clock::now() >= slot.deadline;
      if (fds[i].revents == 0 && !timed_out) continue;
      const HostWorker::Read r = slot.worker->read_available();
      if (r == HostWorker::Read::kResult) {
        submit(slot);
      } else if (r == HostWorker::Read::kError) {
        const std::string message(slot.worker->payload().begin(), slot.worker->payload().end());
        fail(slot, "host worker failed: " + message, false);
      } else if (r == HostWorker::Read::kClosed) {
        fail(slot, "host worker " + slot.worker->kill_and_reap(), false);
      } else if (timed_out) {
        slot.worker->kill_and_reap();
        fail(slot,
             "host timed out after " + seconds_text(options_.sample_timeout) + " s (worker killed)",
             true);
      }
    }
  }

  void submit(Slot& slot) {
    const std::vector<std::uint8_t>& bytes = slot.worker->payload();
    const cadinterp_status s = cadinterp_build_session_submit_serialized(
        session_, slot.job->id, bytes.data(), bytes.size());
    if (s == CADINTERP_E_INVALID_ARGUMENT) {
      fail(slot, "host worker answered bytes that are not a sample", false);
      return;
    }
    // Another failure (cancelled, store not writable) ends the session: run() sees it done.
    if (s == CADINTERP_OK) ++summary_.answered;
    slot.job.reset();
  }

  // The slot's worker failed its request: a fresh worker replaces it and gets the request once
  // more; after a second failure the point is answered infeasible with `message`.
  void fail(Slot& slot, const std::string& message, bool timed_out) {
    ++(timed_out ? summary_.timeouts : summary_.crashes);
    Job job = std::move(*slot.job);
    slot.job.reset();
    start(slot);
    if (job.attempt == 1) {
      ++summary_.retries;
      job.attempt = 2;
      job.first_failure = message;
      dispatch(slot, std::move(job));
      return;
    }
    give_up(job, message);
  }

  void give_up(const Job& job, const std::string& message) {
    const std::string text =
        job.first_failure == message
            ? message + ", on the first attempt and on a retry in a fresh worker"
            : message + " on a retry in a fresh worker, after: " + job.first_failure;
    cadinterp_sample* out = nullptr;
    if (cadinterp_build_session_sample(session_, job.id, &out) == CADINTERP_OK)
      cadinterp_sample_set_message(out, text.c_str());
    if (cadinterp_build_session_submit(session_, job.id, CADINTERP_E_INFEASIBLE) == CADINTERP_OK) {
      ++summary_.answered;
      ++summary_.given_up;
    }
  }

  cadinterp_build_session* session_;
  const cadinterp_host& host_;
  const IsolationOptions& options_;
  IsolationSummary& summary_;
  std::vector<Slot> slots_;
  std::deque<Job> pending_;
};

}  // namespace

std::string default_worker_executable() {
  if (const char* env = std::getenv("CADINTERP_HOST_WORKER"); env && *env) return env;
  char self[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  std::string dir = ".";
  if (n > 0) {
    const std::string path(self, static_cast<std::size_t>(n));
    const std::size_t slash = path.rfind('/');
    if (slash != std::string::npos) dir = path.substr(0, slash);
  }
  return dir + "/cadinterp-host-worker";
}

cadinterp_status run_isolated(cadinterp_builder* builder, const std::string& output,
                              const cadinterp_host& host, const IsolationOptions& options,
                              IsolationSummary* summary) {
  *summary = IsolationSummary{};
  cadinterp_build_session* session = nullptr;
  cadinterp_status s = cadinterp_build_session_create(builder, &session);
  if (s != CADINTERP_OK) return s;
  try {
    Driver driver(session, host, options, *summary);
    driver.run();
  } catch (const WorkerError&) {
    cadinterp_build_session_destroy(session);  // cancels; the answered samples stay stored
    throw;
  }
  // The driver's workers are stopped before the asset is written.
  s = cadinterp_build_session_finish(session, output.c_str());
  cadinterp_build_session_destroy(session);
  return s;
}

std::string isolation_summary_line(const IsolationSummary& s) {
  char b[320];
  std::snprintf(b, sizeof b,
                "%d workers (%d started), %d requests, %d answered, %d retries, %d infeasible "
                "after a retry; worker failures: %d crashed, %d timed out",
                s.workers, s.started, s.requests, s.answered, s.retries, s.given_up, s.crashes,
                s.timeouts);
  return b;
}

}  // namespace cadinterp::tools
