// Distributed builds on MPI (`mpirun -np N cadinterp build --mpi ...`). Rank 0 drives a build
// session (cadinterp_build_session_*, cadinterp_builder.h) and owns its sample store; ranks
// 1..N-1 load the same host and answer rank 0's requests with the bytes of
// cadinterp_host_evaluate_serialized / cadinterp_host_simulate_serialized, which rank 0 hands to
// cadinterp_build_session_submit_serialized. The asset is the threaded build's, byte for byte.
//
// A rank that dies: Open MPI 4.1 (Debian 12) has no fault-tolerant MPI (ULFM arrives in 5.0), so
// mpirun aborts the whole job when any process dies: it sends SIGTERM to the others and SIGKILL a
// second later (odls_base_sigkill_timeout). Rank 0 turns SIGTERM into a cancel of the session:
// every sample it accepted is already committed to the store (one SQLite commit per sample), so
// running the same command again resumes with only the missing points. Compiled only when CMake
// finds MPI (CADINTERP_WITH_MPI); docs/distributed-builds.md has the measurements.
#pragma once

#include <csignal>
#include <string>

#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::tools::mpi {

/// The MPI job as this process sees it. MPI_Init_thread (MPI_THREAD_FUNNELED: only the thread
/// that constructs it calls MPI; the builder's own threads never do) on construction; on
/// destruction rank 0 tells the other ranks to stop (if not done yet), then MPI_Finalize, unless
/// abandon() was called. One per process; not thread-safe.
class World {
 public:
  /// Throws std::runtime_error when MPI cannot start.
  World();
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Rank 0: sends every other rank the stop message (once; later calls do nothing).
  void stop_workers();
  /// Skips the stop messages and MPI_Finalize at destruction: after a peer died, finalizing would
  /// wait for it forever, and mpirun is ending the job anyway.
  void abandon() { abandoned_ = true; }

 private:
  int rank_ = 0;
  int size_ = 1;
  bool workers_stopped_ = false;
  bool abandoned_ = false;
};

/// What rank 0's driver did (also when it stopped early).
struct DriveResult {
  /// cadinterp_build_session_create's or _finish's status; CADINTERP_E_CANCELLED after a stop.
  cadinterp_status status = CADINTERP_OK;
  /// A signal stopped the run: SIGTERM or SIGINT (mpirun sends SIGTERM when a rank died or on
  /// Ctrl-C). The other ranks may be dead: abandon the World.
  int stop_signal = 0;
  int worker_ranks = 0;
  int answers_received = 0;  ///< answers the session accepted (each committed to the store)
  double wall_seconds = 0;
  double cpu_seconds = 0;  ///< rank 0's CPU time over the run, every thread (getrusage)
};

/// Rank 0 (world.size() >= 2): checks that every rank loaded the same host (identity and
/// parameter count), then runs a session on `builder` with one request in flight per rank until
/// the build is done, and finishes it to `output_path`. Stops early when *stop becomes nonzero
/// (set it from a SIGTERM/SIGINT handler; the value is reported as stop_signal, and a line on
/// stderr says how many answers were accepted). Throws
/// std::runtime_error when a rank could not load the host or loaded another one, or sent a message
/// out of protocol; the builder's report and error describe the run otherwise. MPI errors abort
/// the job (MPI_ERRORS_ARE_FATAL, the default).
DriveResult drive(World& world, cadinterp_builder* builder, const cadinterp_host* host,
                  const std::string& output_path, const volatile std::sig_atomic_t* stop);

/// Ranks >= 1: tells rank 0 which host it loaded (or load_error when host is NULL; then it
/// returns after rank 0's stop), then answers rank 0's requests until rank 0 says stop. Returns
/// the number of requests answered. MPI errors abort the job; an answer a message cannot carry
/// (over 2 GiB) makes its point infeasible with that message.
int serve(const World& world, const cadinterp_host* host, const std::string& load_error);

}  // namespace cadinterp::tools::mpi
