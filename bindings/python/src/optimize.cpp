// cadinterp._cadinterp._Problem: libcadinterp_optimize's problem (cadinterp_optimize.h) for the
// Python class cadinterp.Problem (cadinterp/_optimize.py adds the expression front end, the
// result object and the scipy adapters). Compiled only when the build has the optimizer
// (CADINTERP_PY_WITH_OPTIMIZE, set by CMakeLists.txt when the target cadinterp_optimize exists).
//
// Ipopt runs without the GIL; the progress callback takes it for the Python call. A problem is
// used by one thread at a time (cadinterp_optimize.h): a mutex, taken without blocking, turns a
// second call during a running one (another thread, or the progress callback itself) into a
// RuntimeError instead of a data race or a deadlock.
#include <cmath>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_optimize.h"
#include "runtime.h"

namespace cadinterp_py {

namespace {

/// The Python callable of a solve's progress, and the exception it raised (which stops Ipopt and
/// is raised again once the solve returns).
struct Progress {
  py::object fn;
  int k = 0;
  std::optional<py::error_already_set> error;
};

int progress_trampoline(void* user, int start, int iteration, const double* x, double objective,
                        double violation, double optimality) {
  auto* p = static_cast<Progress*>(user);
  py::gil_scoped_acquire gil;
  try {
    py::array_t<double> xa(p->k);
    std::copy(x, x + p->k, xa.mutable_data());
    py::object stop = p->fn(start, iteration, xa, objective, violation, optimality);
    return stop.is_none() ? 0 : static_cast<int>(py::bool_(stop));
  } catch (py::error_already_set& e) {
    p->error = e;
    return 1;
  }
}

class Problem {
 public:
  explicit Problem(py::object asset) : asset_(std::move(asset)) {
    const Asset& a = asset_.cast<const Asset&>();
    pool_ = a.pool();
    k_ = a.parameter_count();
    if (cadinterp_optimize_create(pool_->asset(), &problem_) != CADINTERP_OK)
      throw StatusError(CADINTERP_E_OUT_OF_MEMORY, "cadinterp_optimize_create failed");
  }
  Problem(const Problem&) = delete;
  Problem& operator=(const Problem&) = delete;
  ~Problem() { cadinterp_optimize_destroy(problem_); }

  void parse(int function, const std::string& expression) {
    auto lock = acquire();
    check(cadinterp_optimize_parse(problem_, function, expression.c_str()));
  }
  int parse_constraint(const std::string& constraint) {
    auto lock = acquire();
    int function = 0;
    check(cadinterp_optimize_parse_constraint(problem_, constraint.c_str(), &function));
    return function;
  }
  int add_constraint(double lower, double upper) {
    auto lock = acquire();
    int function = 0;
    check(cadinterp_optimize_add_constraint(problem_, lower, upper, &function));
    return function;
  }
  void add_term(int function, int quantity, double weight, py::handle field, int component,
                py::handle region, double parameter, py::handle direction) {
    const Asset& a = asset_.cast<const Asset&>();
    cadinterp_optimize_term t;
    cadinterp_optimize_term_init(&t, static_cast<cadinterp_optimize_quantity>(quantity));
    t.weight = weight;
    t.field = field.is_none() ? -1 : a.field_index(field);
    t.component = component;
    t.region = a.region_index(region);
    t.parameter = parameter;
    auto dir = CArray<double>::ensure(direction);
    if (!dir || dir.ndim() != 1 || dir.shape(0) != 3)
      throw py::value_error("direction must be 3 real numbers");
    std::copy(dir.data(), dir.data() + 3, t.direction);
    auto lock = acquire();
    check(cadinterp_optimize_add_term(problem_, function, &t));
  }
  void set_bounds(int i, double lower, double upper) {
    auto lock = acquire();
    check(cadinterp_optimize_set_bounds(problem_, i, lower, upper));
  }
  int constraint_count() const { return cadinterp_optimize_constraint_count(problem_); }

  /// (values: 1 + m, gradients: (1 + m) by K or None) at x.
  py::tuple evaluate(py::handle x, bool gradient) {
    const auto xa = as_point(x, k_);
    auto lock = acquire();
    const py::ssize_t n = 1 + constraint_count();
    py::array_t<double> values(n);
    py::object grads = py::none();
    double* g = nullptr;
    if (gradient) {
      py::array_t<double> a({n, static_cast<py::ssize_t>(k_)});
      g = a.mutable_data();
      grads = a;
    }
    double* v = values.mutable_data();
    cadinterp_status s;
    {
      py::gil_scoped_release release;
      s = cadinterp_optimize_evaluate(problem_, xa.data(), v, g);
    }
    if (s != CADINTERP_OK) asset_.cast<const Asset&>().fail(s, message(), xa.data());
    return py::make_tuple(values, grads);
  }

  py::dict solve(py::handle start, int multistart, int max_iterations, double tolerance,
                 int print_level, py::object progress);

 private:
  std::unique_lock<std::mutex> acquire() {
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock())
      throw std::runtime_error(
          "this cadinterp.Problem is in use by another call (a solve running, in this thread's "
          "progress callback or another thread): one call at a time");
    return lock;
  }
  std::string message() const { return cadinterp_optimize_error(problem_); }
  void check(cadinterp_status s) const {
    if (s != CADINTERP_OK) throw StatusError(s, message());
  }

  py::object asset_;  // the cadinterp.Asset (field and region names, error messages)
  std::shared_ptr<WorkspacePool> pool_;  // keeps the C asset open while the problem lives
  int k_ = 0;
  cadinterp_optimize_problem* problem_ = nullptr;
  std::mutex mutex_;
};

py::array_t<double> copy_rows(const double* data, py::ssize_t rows, py::ssize_t cols) {
  py::array_t<double> a({rows, cols});
  if (rows * cols > 0) std::copy(data, data + rows * cols, a.mutable_data());
  return a;
}

py::dict Problem::solve(py::handle start, int multistart, int max_iterations, double tolerance,
                        int print_level, py::object progress) {
  py::array_t<double> start_x;
  if (!start.is_none()) start_x = as_point(start, k_);
  auto lock = acquire();
  cadinterp_optimize_options o;
  cadinterp_optimize_options_init(&o);
  o.multistart = multistart;
  o.max_iterations = max_iterations;
  o.tolerance = tolerance;
  o.print_level = print_level;
  o.start = start.is_none() ? nullptr : start_x.data();
  Progress p;
  p.k = k_;
  if (!progress.is_none()) {
    p.fn = progress;
    o.progress = progress_trampoline;
    o.progress_user = &p;
  }
  cadinterp_optimize_result r{};
  r.struct_size = sizeof r;
  cadinterp_status s;
  {
    py::gil_scoped_release release;
    s = cadinterp_optimize_solve(problem_, &o, &r);
  }
  if (p.error) throw *p.error;
  check(s);
  const py::ssize_t k = r.parameter_count, m = r.constraint_count;
  py::dict d;
  d["x"] = copy_rows(r.x, 1, k).reshape({k});
  d["objective"] = r.objective;
  d["constraints"] = copy_rows(r.constraints, 1, m).reshape({m});
  d["constraint_violation"] = r.constraint_violation;
  d["gradient_norm"] = r.gradient_norm;
  d["optimality"] = r.optimality;
  d["converged"] = r.converged != 0;
  d["ipopt_status"] = r.ipopt_status;
  d["status"] = std::string(r.status ? r.status : "");
  d["iterations"] = r.iterations;
  d["evaluations"] = r.evaluations;
  d["refused_evaluations"] = r.refused_evaluations;
  d["starts"] = r.starts;
  d["best_start"] = r.best_start;
  d["path"] = copy_rows(r.path, r.path_length, k);
  d["path_objective"] =
      copy_rows(r.path_objective, 1, r.path_length).reshape({py::ssize_t(r.path_length)});
  d["error_estimate"] =
      r.error_estimate < 0 ? py::object(py::none()) : py::float_(r.error_estimate);
  d["linear_asset"] = r.linear_asset != 0;
  d["note"] = std::string(r.note ? r.note : "");
  return d;
}

}  // namespace

void init_optimize(py::module_& m) {
  using py::arg;
  py::class_<Problem>(m, "_Problem", "libcadinterp_optimize's problem; use cadinterp.Problem.")
      .def(py::init<py::object>(), arg("asset"))
      .def("parse", &Problem::parse, arg("function"), arg("expression"))
      .def("parse_constraint", &Problem::parse_constraint, arg("constraint"))
      .def("add_constraint", &Problem::add_constraint, arg("lower"), arg("upper"))
      .def("add_term", &Problem::add_term, arg("function"), arg("quantity"), arg("weight"),
           arg("field"), arg("component"), arg("region"), arg("parameter"), arg("direction"))
      .def("set_bounds", &Problem::set_bounds, arg("i"), arg("lower"), arg("upper"))
      .def("constraint_count", &Problem::constraint_count)
      .def("evaluate", &Problem::evaluate, arg("x"), arg("gradient"))
      .def("solve", &Problem::solve, arg("start"), arg("multistart"), arg("max_iterations"),
           arg("tolerance"), arg("print_level"), arg("progress"));
}

}  // namespace cadinterp_py
