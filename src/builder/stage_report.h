// What the build's stages share to fill BuildReport (build.h) on every exit path: the wall-time
// timer of a stage, and the counting of distinct failure reasons with their text for exception
// messages.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

#include "builder/build.h"

namespace cadinterp::builder {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Adds the wall time of a scope to `total` when the scope ends, by return or by exception, so a
// failed build still reports where its time went. `excluded` (may be null) is a stage timed
// inside this one: its growth during the scope is subtracted.
class StageTimer {
 public:
  StageTimer(double& total, const double* excluded = nullptr)
      : total_(total), excluded_(excluded), excluded0_(excluded ? *excluded : 0.0) {}
  ~StageTimer() { total_ += seconds_since(t0_) - (excluded_ ? *excluded_ - excluded0_ : 0.0); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  double& total_;
  const double* excluded_;
  double excluded0_;
  Clock::time_point t0_ = Clock::now();
};

// Counts `message` among the first kMaxReasons distinct ones (first-seen order), or in `other`.
void count_reason(std::vector<BuildReport::Reason>& reasons, int& other, const std::string& message,
                  const std::vector<double>& x);

// "'a' x3; 'b' x1; 2 more with other messages": the first `shown` reasons, for exception
// messages (each message cut to 200 characters: hosts may return long diagnostics).
std::string reasons_text(const std::vector<BuildReport::Reason>& reasons, int other,
                         std::size_t shown = 3);

}  // namespace cadinterp::builder
