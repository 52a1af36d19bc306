// Where host evaluations run. The sampler hands an executor one refinement wave of parameter
// points and receives one Sample per point; it never sees threads, processes or ranks. The
// mapped-mesh simulations of simulate_mapped (paper §6) go through the same executor, so that
// nothing else in the builder calls the host: a thread pool (here) and a build session
// (build_session.h: requests answered by whoever drives it, on any thread, process or rank) are
// interchangeable without touching the sampler.
#pragma once

#include <functional>
#include <vector>

#include "builder/mesh_types.h"

namespace cadinterp::builder {

class Executor {
 public:
  virtual ~Executor() = default;
  /// Evaluates every point (K doubles each). Calls done(i, sample) exactly once per point that
  /// was evaluated, on the calling thread, in completion order; between deliveries it calls
  /// cancelled(), and once that returns true no new point is started. Returns false when
  /// cancelled before every point was delivered.
  virtual bool run(const std::vector<std::vector<double>>& points,
                   const std::function<void(std::size_t, Sample&&)>& done,
                   const std::function<bool()>& cancelled) = 0;
  /// The host's simulate at x (K values) on `mesh` (Host::simulate). Blocks until answered; may
  /// be called from any builder thread, concurrently. Throws BuildCancelled when the build is
  /// cancelled meanwhile.
  virtual Sample simulate(const std::vector<double>& x, const Sample& mesh) = 0;
  /// Evaluations that may run at once.
  virtual int concurrency() const = 0;
};

/// Runs the host on `threads` threads (a host that is not thread-safe is still called one at a
/// time, by Host::evaluate).
class ThreadPoolExecutor final : public Executor {
 public:
  ThreadPoolExecutor(const Host& host, int threads);
  bool run(const std::vector<std::vector<double>>& points,
           const std::function<void(std::size_t, Sample&&)>& done,
           const std::function<bool()>& cancelled) override;
  Sample simulate(const std::vector<double>& x, const Sample& mesh) override {
    return host_.simulate(x.data(), mesh);
  }
  int concurrency() const override { return threads_; }

 private:
  const Host& host_;
  int threads_;
};

}  // namespace cadinterp::builder
