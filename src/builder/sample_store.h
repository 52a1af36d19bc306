// The resumable sample store: an SQLite file of finished host evaluations keyed by parameter
// vector, so that a build killed at any moment (kill -9 included) resumes without evaluating any
// finished sample again. Each sample is committed in its own transaction as soon as the host
// returns it (WAL journal: a commit is one append, and a killed process loses at most the
// samples still running). Infeasible samples are kept too, with their messages: the host is
// deterministic, so repeating them would only repeat the failure.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "builder/mesh_types.h"

struct sqlite3;
struct sqlite3_stmt;

namespace cadinterp::builder {

struct StoreError : std::runtime_error {
  enum class Kind { Io, Mismatch };
  StoreError(Kind k, const std::string& m) : std::runtime_error(m), kind(k) {}
  Kind kind;
};

class SampleStore {
 public:
  /// Opens or creates the store at `path`. `fingerprint` names what the samples are samples of
  /// (host name, identity, parameter box); a store created with another fingerprint is refused
  /// (StoreError::Mismatch). Other failures: StoreError::Io.
  SampleStore(const std::string& path, const std::string& fingerprint);
  ~SampleStore();
  SampleStore(const SampleStore&) = delete;
  SampleStore& operator=(const SampleStore&) = delete;

  /// The sample at x (K values, compared bit for bit), if stored. A stored sample that fails to
  /// decode is treated as absent (and will be overwritten).
  bool get(const std::vector<double>& x, Sample& out);
  /// Stores the sample at x, replacing any previous one; durable when this returns.
  void put(const std::vector<double>& x, const Sample& s);
  /// Number of stored samples.
  std::int64_t size();
  /// Every stored parameter vector (for tests and tools).
  std::vector<std::vector<double>> keys();

 private:
  sqlite3* db_ = nullptr;
  sqlite3_stmt* get_ = nullptr;
  sqlite3_stmt* put_ = nullptr;
  void check(int rc, const char* what);
};

}  // namespace cadinterp::builder
