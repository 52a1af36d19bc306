// Shared by the translation units of the extension module cadinterp._cadinterp: the exception
// that carries a cadinterp_status to Python, the conversion of parameter points, and read-only
// numpy views whose base keeps the memory they view alive.
#ifndef CADINTERP_PY_COMMON_H
#define CADINTERP_PY_COMMON_H

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "cadinterp/cadinterp.h"

namespace cadinterp_py {

namespace py = pybind11;

/// A non-OK status and the C ABI's message. module.cpp translates it into the Python class of
/// that status (cadinterp/_errors.py), so every C failure reaches Python as one exception type.
struct StatusError : std::exception {
  StatusError(cadinterp_status s, std::string m) : status(s), message(std::move(m)) {}
  const char* what() const noexcept override { return message.c_str(); }
  cadinterp_status status;
  std::string message;
};

/// A numpy array of T in C order: a conversion target that copies only when it must.
template <class T>
using CArray = py::array_t<T, py::array::c_style | py::array::forcecast>;

/// The Python exception object for `status` with `message` (an instance of the class
/// cadinterp._errors.error_class(status) returns). Needs the GIL.
py::object make_error(cadinterp_status status, const std::string& message);

/// x as K contiguous doubles: a float64 array that is already so is used as it is, anything
/// else numpy can read as reals is converted. A K=1 asset also takes a scalar.
/// TypeError for values that are not real numbers, ValueError for another shape.
py::array_t<double> as_point(py::handle x, int k);
/// X as N rows of K contiguous doubles (K=1 also takes a 1-D array of N values); errors as
/// as_point.
py::array_t<double> as_points(py::handle x, int k);

/// A read-only array of `shape` over `data`, whose base is `owner`: the view keeps the owner
/// (and whatever the owner keeps) alive, and cannot be written through.
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, py::handle owner) {
  py::array a(py::dtype::of<T>(), std::move(shape), {}, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

void init_runtime(py::module_& m);
void init_builder(py::module_& m);
/// cadinterp._cadinterp._Problem (optimize.cpp), in builds with libcadinterp_optimize only.
void init_optimize(py::module_& m);

}  // namespace cadinterp_py

#endif  // CADINTERP_PY_COMMON_H
