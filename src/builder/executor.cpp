#include "builder/executor.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>

namespace cadinterp::builder {

ThreadPoolExecutor::ThreadPoolExecutor(const Host& host, int threads)
    : host_(host), threads_(std::max(1, threads)) {}

bool ThreadPoolExecutor::run(const std::vector<std::vector<double>>& points,
                             const std::function<void(std::size_t, Sample&&)>& done,
                             const std::function<bool()>& cancelled) {
  const std::size_t n = points.size();
  if (n == 0) return true;
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::mutex mu;
  std::condition_variable ready;
  std::deque<std::pair<std::size_t, Sample>> finished;
  std::exception_ptr error;  // std::bad_alloc from Host::evaluate

  auto work = [&] {
    for (;;) {
      if (stop.load()) return;
      const std::size_t i = next.fetch_add(1);
      if (i >= n) return;
      try {
        Sample s = host_.evaluate(points[i].data());
        std::lock_guard<std::mutex> lock(mu);
        finished.emplace_back(i, std::move(s));
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!error) error = std::current_exception();
        stop = true;
      }
      ready.notify_one();
    }
  };
  const int nthreads =
      static_cast<int>(std::min<std::size_t>(n, static_cast<std::size_t>(threads_)));
  std::vector<std::thread> pool;
  for (int t = 0; t < nthreads; ++t) pool.emplace_back(work);

  // Deliver on this thread, as the Executor contract says; poll cancellation at least every
  // 200 ms so that a slow host does not delay a cancel by a whole evaluation of every thread.
  std::size_t delivered = 0, started_limit = n;
  bool was_cancelled = false;
  while (delivered < started_limit) {
    std::unique_lock<std::mutex> lock(mu);
    ready.wait_for(lock, std::chrono::milliseconds(200),
                   [&] { return !finished.empty() || error; });
    if (error) break;
    while (!finished.empty()) {
      auto item = std::move(finished.front());
      finished.pop_front();
      lock.unlock();
      done(item.first, std::move(item.second));
      ++delivered;
      lock.lock();
    }
    lock.unlock();
    if (!was_cancelled && cancelled && cancelled()) {
      was_cancelled = true;
      stop = true;
      // Points already started still finish and are delivered (the store keeps them).
      started_limit = std::min(n, next.load());
    }
  }
  stop = true;
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  // Deliver what finished after the last wait (possible after a cancel).
  for (auto& item : finished) {
    done(item.first, std::move(item.second));
    ++delivered;
  }
  return !was_cancelled || delivered == n;
}

}  // namespace cadinterp::builder
