// cadinterp.Asset: opening (a path or bytes), the asset's description, and the queries that need
// no workspace. The evaluations are in evaluate.cpp; lifetimes are explained in runtime.h.
#include "runtime.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace cadinterp_py {

AssetHandle::~AssetHandle() {
  cadinterp_close(asset);
  if (bytes) {
    // The last owner may be a lease dropped by a thread without the GIL (eval_many's workers).
    py::gil_scoped_acquire gil;
    bytes = py::object();
  }
}

WorkspacePool::~WorkspacePool() {
  for (cadinterp_workspace* ws : free_) cadinterp_workspace_destroy(ws);
}

cadinterp_workspace* WorkspacePool::take() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!free_.empty()) {
      cadinterp_workspace* ws = free_.back();
      free_.pop_back();
      return ws;
    }
  }
  cadinterp_workspace* ws = nullptr;
  const cadinterp_status s = cadinterp_workspace_create(handle_->asset, &ws);
  if (s != CADINTERP_OK) throw StatusError(s, "cannot create a workspace");
  return ws;
}

void WorkspacePool::give(cadinterp_workspace* ws) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.size() < kKeepFree) {
      free_.push_back(ws);
      return;
    }
  }
  cadinterp_workspace_destroy(ws);
}

namespace {

/// The namedtuple classes of cadinterp._types, looked up once at import (leaked references, as
/// the error class in module.cpp).
struct Types {
  py::handle parameter, field, output, region, infeasible_point, provenance;
};
Types g_types;

const char* location_name(cadinterp_field_location l) {
  return l == CADINTERP_PER_TET ? "tet" : "vertex";
}

/// Opens `source`: a path (str or os.PathLike) is memory-mapped; bytes are read in place (the
/// asset keeps the bytes object); any other buffer (bytearray, memoryview, numpy) is copied,
/// since its owner may change it.
std::shared_ptr<AssetHandle> open_source(const py::object& source, std::string* name) {
  auto handle = std::make_shared<AssetHandle>();
  cadinterp_status s;
  const py::object os = py::module_::import("os");
  if (py::isinstance<py::str>(source) || py::isinstance(source, os.attr("PathLike"))) {
    const std::string path = py::str(os.attr("fspath")(source)).cast<std::string>();
    *name = path;
    py::gil_scoped_release release;
    s = cadinterp_open(path.c_str(), &handle->asset);
  } else if (py::isinstance<py::bytes>(source)) {
    char* data = nullptr;
    py::ssize_t size = 0;
    PyBytes_AsStringAndSize(source.ptr(), &data, &size);
    *name = std::to_string(size) + " bytes";
    handle->bytes = source;
    py::gil_scoped_release release;
    s = cadinterp_open_memory(data, static_cast<std::size_t>(size), 0, &handle->asset);
  } else if (PyObject_CheckBuffer(source.ptr())) {
    const py::buffer_info b = py::reinterpret_borrow<py::buffer>(source).request();
    const std::size_t size = static_cast<std::size_t>(b.size * b.itemsize);
    static const char kEmpty = 0;  // the C ABI takes no NULL, even for 0 bytes
    const void* data = b.ptr ? b.ptr : &kEmpty;
    *name = std::to_string(size) + " bytes";
    py::gil_scoped_release release;
    s = cadinterp_open_memory(data, size, 1, &handle->asset);
  } else {
    throw py::type_error(
        "Asset() takes a path (str or os.PathLike) or the bytes of an asset, got " +
        py::str(py::type::of(source)).cast<std::string>());
  }
  if (s != CADINTERP_OK) throw StatusError(s, cadinterp_open_error());
  return handle;
}

void check(cadinterp_status s, const char* what) {
  if (s != CADINTERP_OK) throw StatusError(s, std::string(what) + " failed");
}

}  // namespace

Asset::Asset(py::object source) {
  auto handle = open_source(source, &source_);
  read_metadata(handle->asset);
  pool_ = std::make_shared<WorkspacePool>(std::move(handle));
}

/// Everything the asset describes, copied into Python objects at open, so that it stays
/// readable after close() and costs nothing per query.
void Asset::read_metadata(const cadinterp_asset* a) {
  k_ = cadinterp_parameter_count(a);
  py::list parameters, fields, outputs, regions, infeasible;
  py::array_t<double> bounds({static_cast<py::ssize_t>(k_), py::ssize_t{2}});
  for (int i = 0; i < k_; ++i) {
    cadinterp_parameter_info p{};
    check(cadinterp_parameter(a, i, &p), "cadinterp_parameter");
    parameters.append(g_types.parameter(p.name, p.lower, p.upper, p.unit));
    parameter_names_.push_back(p.name);
    lower_.push_back(p.lower);
    upper_.push_back(p.upper);
    bounds.mutable_at(i, 0) = p.lower;
    bounds.mutable_at(i, 1) = p.upper;
  }
  for (int i = 0; i < cadinterp_field_count(a); ++i) {
    cadinterp_field_info f{};
    const char* unit = "";
    check(cadinterp_field(a, i, &f), "cadinterp_field");
    check(cadinterp_field_unit(a, i, &unit), "cadinterp_field_unit");
    fields_.push_back({f.name, f.location, f.components});
    fields.append(
        g_types.field(f.name, location_name(f.location), f.components, unit, f.max_abs_error));
  }
  for (int i = 0; i < cadinterp_output_count(a); ++i) {
    const char *name = nullptr, *unit = nullptr;
    check(cadinterp_output(a, i, &name, &unit), "cadinterp_output");
    output_names_.emplace_back(name);
    outputs.append(g_types.output(name, unit ? unit : ""));
  }
  for (int i = 0; i < cadinterp_region_count(a); ++i) {
    cadinterp_region_info r{};
    check(cadinterp_region(a, i, &r), "cadinterp_region");
    py::array_t<int32_t> tags(r.face_tag_count);
    if (r.face_tag_count > 0)
      std::copy(r.face_tags, r.face_tags + r.face_tag_count, tags.mutable_data());
    regions.append(g_types.region(r.name, r.kind, tags));
  }
  for (int i = 0; i < cadinterp_infeasible_point_count(a); ++i) {
    py::array_t<double> x(k_);
    const char* message = nullptr;
    check(cadinterp_infeasible_point(a, i, x.mutable_data(), &message),
          "cadinterp_infeasible_point");
    infeasible.append(g_types.infeasible_point(x, message ? message : ""));
  }
  cadinterp_provenance prov{};
  check(cadinterp_asset_provenance(a, &prov), "cadinterp_asset_provenance");
  int major = 0, minor = 0;
  check(cadinterp_asset_format(a, &major, &minor), "cadinterp_asset_format");
  info_["parameters"] = parameters;
  info_["bounds"] = bounds;
  info_["fields"] = fields;
  info_["outputs"] = outputs;
  info_["regions"] = regions;
  info_["infeasible_points"] = infeasible;
  info_["provenance"] = g_types.provenance(prov.builder_version, prov.host, prov.options);
  info_["format_version"] = py::make_tuple(major, minor);
  info_["degree"] = cadinterp_degree(a);
  info_["element_count"] = cadinterp_element_count(a);
}

py::object Asset::describe(const char* what) const { return info_[what]; }

void Asset::fail(cadinterp_status s, std::string message, const double* x) const {
  if (s == CADINTERP_E_OUTSIDE_DOMAIN) {
    for (std::size_t i = 0; i < lower_.size(); ++i) {
      const std::string at = "x[" + std::to_string(i) + "] (" + parameter_names_[i] + ") = ";
      if (!std::isfinite(x[i])) {
        message += "; " + at + py::str(py::float_(x[i])).cast<std::string>() + " is not finite";
        break;
      }
      if (x[i] < lower_[i] || x[i] > upper_[i]) {
        message += "; " + at + py::str(py::float_(x[i])).cast<std::string>() + " is outside [" +
                   py::str(py::float_(lower_[i])).cast<std::string>() + ", " +
                   py::str(py::float_(upper_[i])).cast<std::string>() + "]";
        break;
      }
    }
  }
  throw StatusError(s, std::move(message));
}

std::shared_ptr<WorkspacePool> Asset::pool() const {
  if (!pool_) throw py::value_error("the asset is closed");
  return pool_;
}

int Asset::region_index(py::handle key) const {
  if (key.is_none()) return -1;
  const cadinterp_asset* a = pool()->asset();
  const int n = cadinterp_region_count(a);
  if (py::isinstance<py::str>(key)) {
    const std::string name = key.cast<std::string>();
    std::string known;
    for (int i = 0; i < n; ++i) {
      cadinterp_region_info r{};
      if (cadinterp_region(a, i, &r) != CADINTERP_OK) continue;
      if (name == r.name) return i;
      known += (known.empty() ? "" : ", ") + std::string(r.name);
    }
    throw StatusError(CADINTERP_E_NOT_FOUND, "no region named '" + name + "' (the asset has: " +
                                                 (known.empty() ? "no regions" : known) + ")");
  }
  if (py::isinstance<py::int_>(key) && !py::isinstance<py::bool_>(key)) {
    const long i = key.cast<long>();
    if (i < 0 || i >= n)
      throw StatusError(CADINTERP_E_INVALID_ARGUMENT, "region index " + std::to_string(i) +
                                                          " is out of range (the asset has " +
                                                          std::to_string(n) + " regions)");
    return static_cast<int>(i);
  }
  throw py::type_error("a region is named by its name (str), its index (int) or None, got " +
                       py::str(py::type::of(key)).cast<std::string>());
}

int Asset::field_index(py::handle key) const {
  if (py::isinstance<py::str>(key)) {
    const std::string name = key.cast<std::string>();
    for (std::size_t i = 0; i < fields_.size(); ++i)
      if (fields_[i].name == name) return static_cast<int>(i);
    std::string known;
    for (const FieldMeta& f : fields_) known += (known.empty() ? "" : ", ") + f.name;
    throw StatusError(CADINTERP_E_NOT_FOUND, "no field named '" + name + "' (the asset has: " +
                                                 (known.empty() ? "no fields" : known) + ")");
  }
  if (py::isinstance<py::int_>(key) && !py::isinstance<py::bool_>(key)) {
    const long i = key.cast<long>();
    if (i < 0 || i >= static_cast<long>(fields_.size()))
      throw StatusError(CADINTERP_E_INVALID_ARGUMENT,
                        "field index " + std::to_string(i) + " is out of range (the asset has " +
                            std::to_string(fields_.size()) + " fields)");
    return static_cast<int>(i);
  }
  throw py::type_error("a field is named by its name (str) or its index (int), got " +
                       py::str(py::type::of(key)).cast<std::string>());
}

FieldSelection Asset::select(py::handle fields) const {
  FieldSelection sel;
  if (fields.is_none()) {
    for (std::size_t i = 0; i < fields_.size(); ++i) sel.indices.push_back(static_cast<int>(i));
    return sel;
  }
  auto add = [&](py::handle key) {
    const int i = field_index(key);
    if (std::find(sel.indices.begin(), sel.indices.end(), i) == sel.indices.end())
      sel.indices.push_back(i);
  };
  if (py::isinstance<py::str>(fields) || py::isinstance<py::int_>(fields)) {
    add(fields);
  } else {
    for (py::handle key : py::iter(fields)) add(key);
  }
  return sel;
}

py::tuple Asset::locate(py::handle x) const {
  const auto p = pool();
  const auto xa = as_point(x, k_);
  int element = -1, feasible = 0;
  const cadinterp_status s = cadinterp_locate(p->asset(), xa.data(), &element, &feasible);
  if (s != CADINTERP_OK) fail(s, "x is outside the parameter box or not finite", xa.data());
  return py::make_tuple(element, feasible != 0);
}

double Asset::error_estimate(py::handle x) const {
  const auto p = pool();
  const auto xa = as_point(x, k_);
  double e = 0;
  const cadinterp_status s = cadinterp_error_estimate(p->asset(), xa.data(), &e);
  if (s != CADINTERP_OK)
    fail(s, "no error estimate at x (outside the box, or an infeasible element)", xa.data());
  return e < 0 ? std::nan("") : e;
}

py::dict Asset::error_estimates(py::handle x) const {
  const auto p = pool();
  const auto xa = as_point(x, k_);
  int count = 0;
  cadinterp_error_estimates(p->asset(), xa.data(), nullptr, 0, &count);
  std::vector<double> e(static_cast<std::size_t>(count));
  const cadinterp_status s =
      cadinterp_error_estimates(p->asset(), xa.data(), e.data(), count, &count);
  if (s != CADINTERP_OK)
    fail(s, "no error estimates at x (outside the box, or an infeasible element)", xa.data());
  py::dict d;
  for (int q = 0; q < count; ++q) {
    cadinterp_field_info f{};
    if (q) cadinterp_field(p->asset(), q - 1, &f);
    const double v = e[static_cast<std::size_t>(q)];
    d[q ? f.name : "geometry"] = v < 0 ? std::nan("") : v;
  }
  return d;
}

py::tuple Asset::element_mesh_size(int element) const {
  const auto p = pool();
  uint32_t v = 0, t = 0, f = 0;
  const cadinterp_status s = cadinterp_element_mesh_size(p->asset(), element, &v, &t, &f);
  if (s != CADINTERP_OK)
    throw StatusError(s, "element " + std::to_string(element) + " is out of range (0.." +
                             std::to_string(cadinterp_element_count(p->asset()) - 1) + ")");
  return py::make_tuple(v, t, f);
}

void Asset::set_cache_budget(std::size_t bytes) const {
  const auto p = pool();
  // The asset is immutable but for its synchronized cache (cadinterp.h).
  check(cadinterp_set_cache_budget(const_cast<cadinterp_asset*>(p->asset()), bytes),
        "cadinterp_set_cache_budget");
}

std::string Asset::repr() const {
  std::string names;
  for (py::handle p : info_["parameters"].cast<py::list>())
    names += (names.empty() ? "" : ", ") + p.attr("name").cast<std::string>();
  return "<cadinterp.Asset " + source_ + ": K=" + std::to_string(k_) + " (" + names + "), " +
         std::to_string(fields_.size()) + " fields" + (pool_ ? "" : ", closed") + ">";
}

void init_runtime(py::module_& m) {
  const py::module_ types = py::module_::import("cadinterp._types");
  for (auto [slot, name] : {std::pair{&g_types.parameter, "Parameter"},
                            {&g_types.field, "Field"},
                            {&g_types.output, "Output"},
                            {&g_types.region, "Region"},
                            {&g_types.infeasible_point, "InfeasiblePoint"},
                            {&g_types.provenance, "Provenance"}}) {
    *slot = types.attr(name);
    slot->inc_ref();
  }
  py::class_<Asset> cls(m, "Asset", R"(An opened asset (.cadi): its description and evaluations.

Asset(source): source is a path (str or os.PathLike; the file is memory-mapped, and must not
change while open) or the bytes of an asset (bytes are read in place and kept referenced;
another buffer is copied). Raises the error class of the C status (BadMagicError, IoError, ...).
Thread-safe: several threads may evaluate one Asset at once (each call leases its own
workspace). A context manager: `with cadinterp.Asset(p) as a:` closes it on exit.)");
  cls.def(py::init<py::object>(), py::arg("source"))
      .def("close", &Asset::close,
           "Lets go of the asset. Arrays of earlier results stay valid: they keep what they view "
           "alive, and the file is unmapped when the last of them is freed. Idempotent.")
      .def_property_readonly("closed", &Asset::closed)
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](Asset& a, py::args) { a.close(); })
      .def("__repr__", &Asset::repr)
      .def_property_readonly("parameter_count", &Asset::parameter_count, "K, the parameters.");
  for (const char* what :
       {"parameters", "bounds", "fields", "outputs", "regions", "infeasible_points", "provenance",
        "format_version", "degree", "element_count"})
    cls.def_property_readonly(what, [what](const Asset& a) { return a.describe(what); });
  cls.def("locate", &Asset::locate, py::arg("x"),
          "(element, feasible): the element holding x and whether eval succeeds there.")
      .def("error_estimate", &Asset::error_estimate, py::arg("x"),
           "The estimated geometric error at x (symmetric Hausdorff distance to the host's mesh "
           "relative to its bounding-box diagonal); NaN when the builder did not measure it.")
      .def("error_estimates", &Asset::error_estimates, py::arg("x"),
           "Estimated errors at x per quantity: {'geometry': relative to the bounding-box "
           "diagonal, field name: relative to the field's range}; NaN where not measured "
           "(assets written before format 1.3).")
      .def("element_mesh_size", &Asset::element_mesh_size, py::arg("element"),
           "(#V, #T, #F) of the meshes eval returns in that element ((0, 0, 0): infeasible).")
      .def("set_cache_budget", &Asset::set_cache_budget, py::arg("bytes"),
           "Byte budget of the cache of decoded elements (default 256 MiB).");
  init_evaluate(m, cls);
}

}  // namespace cadinterp_py
