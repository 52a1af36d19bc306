// cadinterp._cadinterp: the extension module behind the Python package `cadinterp` (see
// bindings/python/README.md). It links libcadinterp, libcadinterp_builder and, in builds that
// have it, libcadinterp_optimize, and uses their public C ABI only (src/DEPENDENCIES.md,
// "Consumers").
#include "cadinterp/cadinterp_builder.h"
#include "common.h"

namespace cadinterp_py {

namespace {

/// cadinterp._errors.error_class, looked up once at import. Kept in a leaked reference: the
/// exception translator may run late in interpreter shutdown, after module globals are gone.
py::handle g_error_class;

/// The values of `obj` as a numpy array, or a TypeError naming what it is when they are not
/// real numbers (strings, objects, complex values).
py::array real_array(py::handle obj, const char* what) {
  py::array a = py::array::ensure(obj);
  if (!a)
    throw py::type_error(std::string(what) + " must be real numbers, got " +
                         py::str(py::type::of(obj)).cast<std::string>());
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(std::string(what) + " must be real numbers, got an array of dtype " +
                         py::str(a.dtype()).cast<std::string>());
  return a;
}

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

py::object make_error(cadinterp_status status, const std::string& message) {
  py::object cls = py::reinterpret_borrow<py::object>(g_error_class)(static_cast<int>(status));
  return cls(message.empty() ? std::string(cadinterp_status_string(status)) : message,
             static_cast<int>(status));
}

py::array_t<double> as_point(py::handle x, int k) {
  // The common case, a float64 vector of K values, costs one type check and no copy.
  using Contiguous = py::array_t<double, py::array::c_style>;
  if (py::isinstance<Contiguous>(x)) {
    auto a = py::reinterpret_borrow<Contiguous>(x);
    if (a.ndim() == 1 && a.shape(0) == k) return a;
  }
  py::array a = real_array(x, "x");
  const bool scalar_ok = k == 1 && a.ndim() == 0;
  if (!scalar_ok && !(a.ndim() == 1 && a.shape(0) == k))
    throw py::value_error("x must hold the asset's " + std::to_string(k) +
                          " parameter values (shape (" + std::to_string(k) + ",)), got shape " +
                          shape_text(a));
  return Contiguous::ensure(a.reshape({static_cast<py::ssize_t>(k)}));
}

py::array_t<double> as_points(py::handle x, int k) {
  py::array a = real_array(x, "X");
  if (k == 1 && a.ndim() == 1) a = a.reshape({a.shape(0), static_cast<py::ssize_t>(1)});
  if (a.ndim() != 2 || a.shape(1) != k)
    throw py::value_error("X must be N points of the asset's " + std::to_string(k) +
                          " parameters (shape (N, " + std::to_string(k) + ")), got shape " +
                          shape_text(a));
  return CArray<double>::ensure(a);
}

}  // namespace cadinterp_py

PYBIND11_MODULE(_cadinterp, m) {
  namespace py = pybind11;
  using cadinterp_py::StatusError;
  m.doc() = "The C ABI of libcadinterp and libcadinterp_builder (use the package `cadinterp`).";
  cadinterp_py::g_error_class = py::module_::import("cadinterp._errors").attr("error_class");
  cadinterp_py::g_error_class.inc_ref();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const StatusError& e) {
      py::object err = cadinterp_py::make_error(e.status, e.message);
      PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(err.ptr())), err.ptr());
    }
  });

  m.def("version", &cadinterp_version, "Version of the libcadinterp in use (MAJOR.MINOR.PATCH).");
  m.def("builder_version", &cadinterp_builder_version,
        "Version of the libcadinterp_builder in use (MAJOR.MINOR.PATCH).");
  m.def(
      "format_version",
      [] {
        int major = 0, minor = 0;
        cadinterp_format_version(&major, &minor);
        return py::make_tuple(major, minor);
      },
      "Newest asset format (major, minor) this libcadinterp reads.");
  m.def(
      "status_string", [](int s) { return cadinterp_status_string(cadinterp_status(s)); },
      py::arg("status"), "The C ABI's fixed text of a status code.");
  cadinterp_py::init_runtime(m);
  cadinterp_py::init_builder(m);
#ifdef CADINTERP_PY_WITH_OPTIMIZE
  cadinterp_py::init_optimize(m);
  m.attr("has_optimizer") = true;
#else
  m.attr("has_optimizer") = false;  // cadinterp.Problem raises OptimizerUnavailableError
#endif
}
