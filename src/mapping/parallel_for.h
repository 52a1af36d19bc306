// The one loop the mapping and the builder run across cores: independent items (sources mapped
// onto a canonical mesh, a wave's refinement tests, the elements of a build) handed out one at a
// time to a few threads. Each item writes its own result slot, so what a caller computes does
// not depend on the thread count or on which thread took which item.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace cadinterp::mapping {

/// Calls f(i) once for every i in [0, n), on up to `threads` threads (the calling thread is one
/// of them; threads <= 1 runs in order on the calling thread). Items are taken in increasing
/// order as threads become free, so long items do not hold up short ones. f must be safe to call
/// concurrently for distinct i. The first exception f throws stops further items from starting
/// and is rethrown here once every thread has finished.
template <class F>
void parallel_for(std::size_t n, int threads, F&& f) {
  const std::size_t workers =
      std::min<std::size_t>(n, static_cast<std::size_t>(std::max(1, threads)));
  if (workers <= 1) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex failure_mu;
  auto work = [&] {
    try {
      for (std::size_t i; (i = next.fetch_add(1)) < n;) f(i);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mu);
      if (!failure) failure = std::current_exception();
      next = n;
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < workers; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace cadinterp::mapping
