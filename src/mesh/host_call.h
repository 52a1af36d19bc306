// The host of a build: a validated, owning copy of the caller's cadinterp_host, and the one
// place where its callbacks are called (guarded: statuses, C++ exceptions and invalid meshes all
// become an infeasible Sample with a message; the build goes on).
#pragma once

#include <chrono>
#include <mutex>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"
#include "mesh/sample.h"

/// The builder-owned object host callbacks write into (cadinterp_builder.h).
struct cadinterp_sample {
  cadinterp::mesh::Sample sample;
  bool mesh_set = false;
};

namespace cadinterp::mesh {

/// What the host wrote, settled: validated and feasible when `err` is "" and validate() finds
/// nothing, else an empty infeasible Sample with the message. The one rule for every path a
/// host's answer takes (Host's own calls, a build session's answers); host_seconds is the
/// caller's to set.
Sample settle(Sample written, std::string err);

class Host {
 public:
  /// Copies `h`; throws std::invalid_argument naming the first inconsistency.
  explicit Host(const cadinterp_host& h);
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  int dim() const { return static_cast<int>(lower_.size()); }
  const std::vector<double>& lower() const { return lower_; }
  const std::vector<double>& upper() const { return upper_; }
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<std::string>& units() const { return units_; }
  const std::string& name() const { return name_; }
  const std::string& identity() const { return identity_; }
  bool thread_safe() const { return host_.thread_safe != 0; }
  bool has_simulate() const { return host_.simulate != nullptr; }

  /// regenerate, references, simulate at x (K values), then validate(). Never throws but for
  /// std::bad_alloc. Thread-safety: concurrent calls when thread_safe(), else serialized here.
  Sample evaluate(const double* x) const;

  /// The host's simulate at x on a mesh other than the one regenerate writes (a mapped one, §6:
  /// the source's geometry in the canonical's combinatorics, with its triangles tagged so that
  /// the host's boundary-condition regions at x name them): a Sample holding that mesh and the
  /// fields, or an infeasible one whose message says why (the host has no simulate, or it
  /// failed). Same guards, validation and thread-safety as evaluate.
  Sample simulate(const double* x, const Sample& mesh) const;

 private:
  // Calls simulate on the mesh set on `out`; "" or why it failed.
  std::string simulate_into(const double* x, cadinterp_sample& out) const;
  // The Sample of a finished evaluation: validated, or infeasible with `err`.
  static Sample finish(cadinterp_sample& out, std::string err,
                       std::chrono::steady_clock::time_point t0);

  cadinterp_host host_{};
  std::string name_, identity_;
  std::vector<std::string> names_, units_;
  std::vector<double> lower_, upper_;
  mutable std::mutex serial_;  // held around the callbacks of a host that is not thread-safe
};

}  // namespace cadinterp::mesh
