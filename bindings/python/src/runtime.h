// The runtime side of the extension module: an opened asset, the pool of workspaces its
// evaluations lease, and the Python class Asset (runtime.cpp: opening and queries; evaluate.cpp:
// eval, grad, vjp, properties and the vectorised eval_many).
//
// Lifetimes (the rule bindings/python/README.md documents): every array an evaluation returns
// views the memory of the workspace that computed it, and its numpy base holds a Lease of that
// workspace. A leased workspace is not used again until every array of its result is gone, so a
// result never changes under its arrays; the lease holds the pool, the pool holds the asset, so
// neither is destroyed while an array views them, whatever Asset.close() and the garbage
// collector do in between.
#ifndef CADINTERP_PY_RUNTIME_H
#define CADINTERP_PY_RUNTIME_H

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common.h"

namespace cadinterp_py {

/// An opened cadinterp_asset; cadinterp_close when the last owner lets go.
struct AssetHandle {
  cadinterp_asset* asset = nullptr;
  /// The bytes object the asset reads when it was opened from bytes without a copy.
  py::object bytes;
  AssetHandle() = default;
  AssetHandle(const AssetHandle&) = delete;
  AssetHandle& operator=(const AssetHandle&) = delete;
  ~AssetHandle();
};

/// Workspaces of one asset, handed out one per evaluation (any thread) and taken back when the
/// evaluation's result is freed. Keeps a few free ones for reuse, so that a loop of evaluations
/// whose results are dropped creates no new workspace.
class WorkspacePool {
 public:
  explicit WorkspacePool(std::shared_ptr<AssetHandle> handle) : handle_(std::move(handle)) {}
  WorkspacePool(const WorkspacePool&) = delete;
  WorkspacePool& operator=(const WorkspacePool&) = delete;
  ~WorkspacePool();
  /// A free workspace, or a new one; StatusError when the C ABI cannot create one.
  cadinterp_workspace* take();
  void give(cadinterp_workspace* ws);
  const cadinterp_asset* asset() const { return handle_->asset; }

 private:
  static constexpr std::size_t kKeepFree = 8;
  std::shared_ptr<AssetHandle> handle_;
  std::mutex mutex_;
  std::vector<cadinterp_workspace*> free_;
};

/// One workspace taken from a pool for as long as the Lease lives (it keeps the pool alive).
class Lease {
 public:
  explicit Lease(std::shared_ptr<WorkspacePool> pool)
      : pool_(std::move(pool)), ws_(pool_->take()) {}
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
  ~Lease() { pool_->give(ws_); }
  cadinterp_workspace* ws() const { return ws_; }
  const cadinterp_asset* asset() const { return pool_->asset(); }
  /// The workspace's message of its last call.
  std::string message() const { return cadinterp_workspace_error(ws_); }

 private:
  std::shared_ptr<WorkspacePool> pool_;
  cadinterp_workspace* ws_;
};

/// What the asset says of field i, copied at open (names stay readable after close()).
struct FieldMeta {
  std::string name;
  cadinterp_field_location location;
  int components;
};

/// Fields chosen by an eval/grad `fields` argument: indices for the C ABI, in order, no repeats.
struct FieldSelection {
  std::vector<int> indices;
};

/// The Python class cadinterp.Asset.
class Asset {
 public:
  explicit Asset(py::object source);
  void close() { pool_.reset(); }
  bool closed() const { return !pool_; }
  int parameter_count() const { return k_; }

  // Queries (runtime.cpp).
  py::object describe(const char* what) const;
  py::tuple locate(py::handle x) const;
  double error_estimate(py::handle x) const;
  py::dict error_estimates(py::handle x) const;
  py::tuple element_mesh_size(int element) const;
  void set_cache_budget(std::size_t bytes) const;
  std::string repr() const;

  // Evaluations (evaluate.cpp).
  py::object eval(py::handle x, py::handle fields) const;
  py::list eval_many(py::handle xs, py::handle fields, int threads,
                     const std::string& errors) const;
  py::object grad(py::handle x, py::handle fields) const;
  py::array_t<double> vjp(py::handle x, py::handle dvertices, py::handle dfields) const;
  py::dict eval_properties(py::handle x, double density, py::handle direction, bool gradient) const;
  py::object integral(py::handle x, py::handle field, int component, py::handle region,
                      bool gradient) const;
  py::object eval_outputs(py::handle x, py::handle outputs, bool gradient) const;

  /// The pool, or ValueError once closed.
  std::shared_ptr<WorkspacePool> pool() const;
  FieldSelection select(py::handle fields) const;
  /// Index of the field named or numbered by `key`: NotFoundError, InvalidArgumentError.
  int field_index(py::handle key) const;
  /// Index of the region named or numbered by `key` (None: -1, the solid): NotFoundError,
  /// InvalidArgumentError.
  int region_index(py::handle key) const;
  const std::vector<FieldMeta>& fields() const { return fields_; }
  /// Throws the status with `message`; for CADINTERP_E_OUTSIDE_DOMAIN, names the first value
  /// of x (K values) outside its range.
  [[noreturn]] void fail(cadinterp_status s, std::string message, const double* x) const;

 private:
  void read_metadata(const cadinterp_asset* a);

  int k_ = 0;
  std::shared_ptr<WorkspacePool> pool_;
  std::vector<FieldMeta> fields_;
  std::vector<std::string> parameter_names_;
  std::vector<std::string> output_names_;
  std::vector<double> lower_, upper_;
  py::dict info_;  // parameters, fields, regions, ... as Python objects, built at open
  std::string source_;
};

void init_evaluate(py::module_& m, py::class_<Asset>& cls);

}  // namespace cadinterp_py

#endif  // CADINTERP_PY_RUNTIME_H
