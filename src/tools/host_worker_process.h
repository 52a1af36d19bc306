// The parent's side of one cadinterp-host-worker process (host_worker.cpp): start it, send it
// requests, read its answers without blocking, and when it crashes, hangs or leaks, kill and
// reap it and say how it ended. Used by the isolated build driver (isolated_driver.h).
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::tools {

/// How to start a worker.
struct WorkerSpec {
  std::string executable;               ///< the cadinterp-host-worker program
  std::string library, model, options;  ///< the host, as `cadinterp build` loads it
  long memory_mb = 0;                   ///< RLIMIT_AS of the worker in MiB (0: no limit)
};

/// A worker that could not be started, or whose host did not load; what() says why.
struct WorkerError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One running worker. Not copyable; not thread-safe (one thread drives it). The destructor
/// closes the worker's socket (an idle worker then exits), kills it when it is busy, and reaps it.
class HostWorker {
 public:
  /// Starts the worker and waits up to `startup_seconds` for its hello. Throws WorkerError when
  /// the executable cannot be run, the host does not load (the worker's message), or the worker
  /// ends or stays silent before it is ready. Ignores SIGPIPE in this process (a worker that
  /// dies mid-request must fail the write, not kill the build).
  HostWorker(const WorkerSpec& spec, double startup_seconds);
  ~HostWorker();
  HostWorker(const HostWorker&) = delete;
  HostWorker& operator=(const HostWorker&) = delete;

  /// What the worker's host says it is (checked against the parent's own load).
  const std::string& host_name() const { return name_; }
  const std::string& host_identity() const { return identity_; }
  pid_t pid() const { return pid_; }
  /// The socket to poll for POLLIN while a request runs.
  int fd() const { return fd_; }

  /// Sends a CADINTERP_REQUEST_SAMPLE (mesh NULL) or CADINTERP_REQUEST_SIMULATE request at x.
  /// Returns false when the worker is gone (then call kill_and_reap).
  bool send(const std::vector<double>& x, const cadinterp_host_mesh* mesh);

  enum class Read {
    kPending,  ///< nothing complete yet
    kResult,   ///< payload() holds the serialized sample
    kError,    ///< payload() holds the worker's message: it could not evaluate
    kClosed    ///< the worker ended or broke the protocol: call kill_and_reap
  };
  /// Reads what the socket holds without blocking.
  Read read_available();
  /// The last complete answer's payload (valid until the next read_available).
  const std::vector<std::uint8_t>& payload() const { return payload_; }

  /// Kills the worker (SIGKILL) unless it has ended, reaps it, and describes how it ended:
  /// "killed by signal 11 (Segmentation fault)", "exited with status 3". Idempotent.
  std::string kill_and_reap();

 private:
  bool send_all(const void* p, std::size_t n);
  std::string wait_hello(double seconds);
  pid_t pid_ = -1;
  int fd_ = -1;
  bool busy_ = false;
  std::string name_, identity_, ended_;
  std::vector<std::uint8_t> buffer_, payload_;
};

/// Blocks up to `seconds` (< 0: no limit) until `worker` answers; kPending means the time ran
/// out. For tests and simple drivers.
HostWorker::Read wait_for_answer(HostWorker& worker, double seconds);

}  // namespace cadinterp::tools
