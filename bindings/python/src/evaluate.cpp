// cadinterp.Asset's evaluations: eval, eval_many, grad, vjp, eval_properties, integral. The GIL is
// released around every C call, so other Python threads run meanwhile. Results view their leased
// workspace (runtime.h).
#include <algorithm>
#include <cmath>
#include <memory>
#include <thread>

#include "runtime.h"

namespace cadinterp_py {

namespace {

/// The Python classes cadinterp.Mesh and cadinterp.Gradient.
struct Mesh {
  int element = -1;
  py::object vertices, tets, triangles, triangle_tags;
  py::dict fields;
};
struct Gradient {
  int element = -1;
  py::object vertices, dvertices;
  py::dict dfields;
};

/// The capsule every array of one result has as base: it owns the lease of the workspace.
py::capsule owner_of(std::unique_ptr<Lease> lease) {
  py::capsule owner(lease.get(), [](void* p) { delete static_cast<Lease*>(p); });
  lease.release();  // the capsule owns it from here
  return owner;
}

/// Shape of one field's array: rows (#V or #T) and, for several components, a second axis;
/// `k` > 0 puts the K derivative blocks first.
std::vector<py::ssize_t> field_shape(const FieldMeta& f, uint32_t vertices, uint32_t tets,
                                     int k = 0) {
  std::vector<py::ssize_t> shape;
  if (k > 0) shape.push_back(k);
  shape.push_back(f.location == CADINTERP_PER_TET ? tets : vertices);
  if (f.components > 1) shape.push_back(f.components);
  return shape;
}

py::object make_mesh(const Asset& asset, std::unique_ptr<Lease> lease, const cadinterp_mesh& m,
                     const FieldSelection& sel) {
  const py::capsule owner = owner_of(std::move(lease));
  Mesh r;
  r.element = m.element;
  const py::ssize_t v = m.vertex_count, t = m.tet_count, f = m.triangle_count;
  r.vertices = view(m.positions, {v, 3}, owner);
  r.tets = view(m.tets, {t, 4}, owner);
  r.triangles = view(m.triangles, {f, 3}, owner);
  r.triangle_tags = view(m.triangle_tags, {f}, owner);
  for (std::size_t i = 0; i < sel.indices.size(); ++i) {
    const FieldMeta& meta = asset.fields()[static_cast<std::size_t>(sel.indices[i])];
    r.fields[meta.name.c_str()] =
        view(m.fields[i], field_shape(meta, m.vertex_count, m.tet_count), owner);
  }
  return py::cast(std::move(r));
}

/// One point of eval_many, evaluated by a worker without the GIL.
struct Slot {
  std::unique_ptr<Lease> lease;
  cadinterp_mesh mesh{};
  cadinterp_status status = CADINTERP_OK;
  std::string message;
};

void eval_slot(const std::shared_ptr<WorkspacePool>& pool, const double* x,
               const FieldSelection& sel, Slot& slot) {
  try {
    slot.lease = std::make_unique<Lease>(pool);
    slot.status = cadinterp_eval(slot.lease->ws(), x, sel.indices.data(),
                                 static_cast<int>(sel.indices.size()), &slot.mesh);
    if (slot.status != CADINTERP_OK) {
      slot.message = cadinterp_workspace_error(slot.lease->ws());
      slot.lease.reset();
    }
  } catch (const StatusError& e) {
    slot.status = e.status;
    slot.message = e.message;
  } catch (const std::bad_alloc&) {
    slot.status = CADINTERP_E_OUT_OF_MEMORY;
    slot.message = "out of memory";
  }
}

/// `v` as a float32 C-contiguous array of exactly `values` values, for an adjoint the C ABI
/// reads without checking its size.
py::array_t<float> adjoint(py::handle v, std::size_t values, const std::string& what) {
  auto a = CArray<float>::ensure(v);
  if (!a) throw py::type_error(what + " must be an array of real numbers");
  if (static_cast<std::size_t>(a.size()) != values)
    throw py::value_error(what + " must hold " + std::to_string(values) +
                          " values for the element holding x, got " + std::to_string(a.size()));
  return a;
}

py::dict properties_dict(const cadinterp_properties& p) {
  py::dict d;
  d["volume"] = p.volume;
  d["mass"] = p.mass;
  d["area"] = p.area;
  d["frontal_area"] = p.frontal_area;
  d["centroid"] = py::array_t<double>(3, p.centroid);
  d["inertia"] = py::array_t<double>({3, 3}, p.inertia);
  return d;
}

/// The K derivative structs stacked per quantity: scalars become (K,), the centroid (K, 3), the
/// inertia (K, 3, 3).
py::dict stacked_gradient(const std::vector<cadinterp_properties>& g) {
  const py::ssize_t k = static_cast<py::ssize_t>(g.size());
  py::dict d;
  const std::pair<const char*, double cadinterp_properties::*> scalars[] = {
      {"volume", &cadinterp_properties::volume},
      {"mass", &cadinterp_properties::mass},
      {"area", &cadinterp_properties::area},
      {"frontal_area", &cadinterp_properties::frontal_area}};
  for (const auto& [name, member] : scalars) {
    py::array_t<double> a(k);
    for (py::ssize_t i = 0; i < k; ++i) a.mutable_at(i) = g[static_cast<std::size_t>(i)].*member;
    d[name] = a;
  }
  py::array_t<double> centroid({k, py::ssize_t{3}}), inertia({k, py::ssize_t{3}, py::ssize_t{3}});
  for (py::ssize_t i = 0; i < k; ++i) {
    const cadinterp_properties& p = g[static_cast<std::size_t>(i)];
    std::copy(p.centroid, p.centroid + 3, centroid.mutable_data(i));
    std::copy(p.inertia, p.inertia + 9, inertia.mutable_data(i));
  }
  d["centroid"] = centroid;
  d["inertia"] = inertia;
  return d;
}

/// Runs `call(ws)` on a workspace leased from the asset's pool, without the GIL: the lease when
/// it succeeds, the error of its status (with the workspace's message) otherwise.
template <class Call>
std::unique_ptr<Lease> leased_call(const Asset& asset, const py::array_t<double>& x, Call&& call) {
  auto lease = std::make_unique<Lease>(asset.pool());
  cadinterp_status s;
  {
    py::gil_scoped_release release;
    s = call(lease->ws());
  }
  if (s != CADINTERP_OK) asset.fail(s, lease->message(), x.data());
  return lease;
}

}  // namespace

py::object Asset::eval(py::handle x, py::handle fields) const {
  pool();  // a closed asset is a ValueError before the arguments are looked at
  const auto xa = as_point(x, k_);
  const FieldSelection sel = select(fields);
  cadinterp_mesh m{};
  auto lease = leased_call(*this, xa, [&](cadinterp_workspace* ws) {
    return cadinterp_eval(ws, xa.data(), sel.indices.data(), static_cast<int>(sel.indices.size()),
                          &m);
  });
  return make_mesh(*this, std::move(lease), m, sel);
}

py::list Asset::eval_many(py::handle xs, py::handle fields, int threads,
                          const std::string& errors) const {
  if (errors != "raise" && errors != "none")
    throw py::value_error("errors must be 'raise' or 'none', got '" + errors + "'");
  if (threads < 0) throw py::value_error("threads must be >= 0 (0: one per core)");
  const auto p = pool();
  const auto points = as_points(xs, k_);
  const FieldSelection sel = select(fields);
  const std::size_t n = static_cast<std::size_t>(points.shape(0));
  std::vector<Slot> slots(n);
  const double* x = points.data();
  std::size_t workers = threads == 0 ? std::thread::hardware_concurrency() : std::size_t(threads);
  workers = std::max<std::size_t>(1, std::min(workers, n));
  {
    py::gil_scoped_release release;
    // Points are dealt round-robin: neighbouring points of a sweep tend to share an element,
    // so each worker's cache reuse is as good as with contiguous chunks and the load is even.
    auto work = [&](std::size_t first) {
      for (std::size_t i = first; i < n; i += workers)
        eval_slot(p, x + i * std::size_t(k_), sel, slots[i]);
    };
    std::vector<std::thread> pool_threads;
    for (std::size_t t = 1; t < workers; ++t) pool_threads.emplace_back(work, t);
    work(0);
    for (std::thread& t : pool_threads) t.join();
  }
  py::list out;
  for (std::size_t i = 0; i < n; ++i) {
    Slot& s = slots[i];
    if (s.status == CADINTERP_OK) {
      out.append(make_mesh(*this, std::move(s.lease), s.mesh, sel));
    } else if (errors == "raise") {
      fail(s.status, "X[" + std::to_string(i) + "]: " + s.message, x + i * std::size_t(k_));
    } else {
      out.append(py::none());
    }
  }
  return out;
}

py::object Asset::grad(py::handle x, py::handle fields) const {
  pool();
  const auto xa = as_point(x, k_);
  const FieldSelection sel = select(fields);
  cadinterp_mesh_grad g{};
  auto lease = leased_call(*this, xa, [&](cadinterp_workspace* ws) {
    return cadinterp_grad(ws, xa.data(), sel.indices.data(), static_cast<int>(sel.indices.size()),
                          &g);
  });
  uint32_t tets = 0;
  if (cadinterp_element_mesh_size(lease->asset(), g.element, nullptr, &tets, nullptr) !=
      CADINTERP_OK)
    throw StatusError(CADINTERP_E_INTERNAL, "grad returned an element out of range");
  const py::capsule owner = owner_of(std::move(lease));
  Gradient r;
  r.element = g.element;
  const py::ssize_t v = g.vertex_count;
  r.vertices = view(g.positions, {v, 3}, owner);
  r.dvertices = view(g.dpositions, {py::ssize_t{k_}, v, 3}, owner);
  for (std::size_t i = 0; i < sel.indices.size(); ++i) {
    const FieldMeta& meta = fields_[static_cast<std::size_t>(sel.indices[i])];
    r.dfields[meta.name.c_str()] =
        view(g.dfields[i], field_shape(meta, g.vertex_count, tets, k_), owner);
  }
  return py::cast(std::move(r));
}

py::array_t<double> Asset::vjp(py::handle x, py::handle dvertices, py::handle dfields) const {
  const auto p = pool();
  const auto xa = as_point(x, k_);
  // The C ABI reads the adjoints without checking their sizes: check them here against the
  // element holding x, so that a wrong shape is a ValueError, never a read out of bounds.
  int element = -1, feasible = 0;
  cadinterp_status s = cadinterp_locate(p->asset(), xa.data(), &element, &feasible);
  if (s != CADINTERP_OK) fail(s, "x is outside the parameter box or not finite", xa.data());
  Lease lease(p);
  if (!feasible) {
    cadinterp_mesh m{};
    s = cadinterp_eval(lease.ws(), xa.data(), nullptr, 0, &m);  // for the C ABI's message
    fail(s == CADINTERP_OK ? CADINTERP_E_INFEASIBLE : s, lease.message(), xa.data());
  }
  uint32_t nv = 0, nt = 0;
  cadinterp_element_mesh_size(p->asset(), element, &nv, &nt, nullptr);
  py::array_t<float> dpos;
  if (!dvertices.is_none()) dpos = adjoint(dvertices, 3 * std::size_t(nv), "dvertices");
  std::vector<int> indices;
  std::vector<py::array_t<float>> arrays;
  if (!dfields.is_none()) {
    if (!py::isinstance<py::dict>(dfields))
      throw py::type_error("dfields must be a dict {field name or index: adjoint array}");
    for (auto item : dfields.cast<py::dict>()) {
      const int i = field_index(item.first);
      const FieldMeta& f = fields_[static_cast<std::size_t>(i)];
      const std::size_t rows = f.location == CADINTERP_PER_TET ? nt : nv;
      indices.push_back(i);
      arrays.push_back(
          adjoint(item.second, rows * std::size_t(f.components), "dfields['" + f.name + "']"));
    }
  }
  std::vector<const float*> ptrs;
  for (const auto& a : arrays) ptrs.push_back(a.data());
  py::array_t<double> out(k_);
  double* dx = out.mutable_data();
  {
    py::gil_scoped_release release;
    s = cadinterp_vjp(lease.ws(), xa.data(), dvertices.is_none() ? nullptr : dpos.data(),
                      indices.data(), ptrs.empty() ? nullptr : ptrs.data(),
                      static_cast<int>(indices.size()), dx);
  }
  if (s != CADINTERP_OK) fail(s, lease.message(), xa.data());
  return out;
}

py::dict Asset::eval_properties(py::handle x, double density, py::handle direction,
                                bool gradient) const {
  pool();
  const auto xa = as_point(x, k_);
  auto dir = CArray<double>::ensure(direction);
  if (!dir || dir.ndim() != 1 || dir.shape(0) != 3)
    throw py::value_error("direction must be 3 real numbers");
  cadinterp_properties props{};
  std::vector<cadinterp_properties> grads(gradient ? std::size_t(k_) : 0);
  leased_call(*this, xa, [&](cadinterp_workspace* ws) {
    return cadinterp_eval_properties(ws, xa.data(), density, dir.data(), &props,
                                     gradient ? grads.data() : nullptr);
  });
  py::dict d = properties_dict(props);
  if (gradient) d["gradient"] = stacked_gradient(grads);
  return d;
}

py::object Asset::integral(py::handle x, py::handle field, int component, py::handle region,
                           bool gradient) const {
  pool();
  const auto xa = as_point(x, k_);
  const int f = field.is_none() ? -1 : field_index(field);
  const int r = region_index(region);
  double value = 0;
  py::array_t<double> grad(gradient ? k_ : 0);
  double* g = gradient ? grad.mutable_data() : nullptr;
  leased_call(*this, xa, [&](cadinterp_workspace* ws) {
    return cadinterp_eval_integral(ws, xa.data(), f, component, r, &value, g);
  });
  if (!gradient) return py::float_(value);
  return py::make_tuple(value, grad);
}

py::object Asset::eval_outputs(py::handle x, py::handle outputs, bool gradient) const {
  pool();
  const auto xa = as_point(x, k_);
  std::vector<int> which;
  const auto add = [&](py::handle key) {
    if (!py::isinstance<py::str>(key))
      throw py::type_error("an output is named by its name (str), got " +
                           py::str(py::type::of(key)).cast<std::string>());
    const std::string name = key.cast<std::string>();
    const auto it = std::find(output_names_.begin(), output_names_.end(), name);
    if (it == output_names_.end()) {
      std::string known;
      for (const std::string& n : output_names_) known += (known.empty() ? "" : ", ") + n;
      throw StatusError(CADINTERP_E_NOT_FOUND, "no output named '" + name + "' (the asset has: " +
                                                   (known.empty() ? "no outputs" : known) + ")");
    }
    which.push_back(static_cast<int>(it - output_names_.begin()));
  };
  if (outputs.is_none()) {
    for (std::size_t i = 0; i < output_names_.size(); ++i) which.push_back(static_cast<int>(i));
  } else if (py::isinstance<py::str>(outputs)) {
    add(outputs);
  } else {
    for (py::handle key : py::iter(outputs)) add(key);
  }
  const auto n = static_cast<py::ssize_t>(which.size());
  std::vector<double> values(which.size());
  std::vector<double> grad(gradient ? which.size() * static_cast<std::size_t>(k_) : 0);
  if (n > 0)
    leased_call(*this, xa, [&](cadinterp_workspace* ws) {
      return cadinterp_eval_outputs(ws, xa.data(), which.data(), static_cast<int>(n), values.data(),
                                    gradient ? grad.data() : nullptr);
    });
  py::dict v, g;
  for (py::ssize_t i = 0; i < n; ++i) {
    const std::string& name = output_names_[static_cast<std::size_t>(which[std::size_t(i)])];
    v[py::str(name)] = values[std::size_t(i)];
    if (gradient) {
      py::array_t<double> d(k_);
      std::copy_n(grad.data() + i * k_, k_, d.mutable_data());
      g[py::str(name)] = d;
    }
  }
  if (!gradient) return std::move(v);
  return py::make_tuple(v, g);
}

void init_evaluate(py::module_& m, py::class_<Asset>& cls) {
  py::class_<Mesh>(m, "Mesh", R"(The mesh at x (Asset.eval). Every array is a read-only view of
the workspace that computed it and keeps that workspace (and the asset) alive: valid for as long
as you hold it, never changed by later evaluations; copy it (np.array(a)) to write to it.)")
      .def_readonly("element", &Mesh::element, "the element holding x")
      .def_readonly("vertices", &Mesh::vertices, "#V by 3 float32 positions")
      .def_readonly("tets", &Mesh::tets, "#T by 4 uint32 vertex indices")
      .def_readonly("triangles", &Mesh::triangles, "#F by 3 uint32, outward")
      .def_readonly("triangle_tags", &Mesh::triangle_tags, "#F int32 face tags (Asset.regions)")
      .def_readonly("fields", &Mesh::fields,
                    "{name: float32 array of #V or #T rows (by components when > 1)}")
      .def("__repr__", [](const Mesh& r) {
        return "<cadinterp.Mesh element " + std::to_string(r.element) + ": " +
               std::to_string(py::len(r.vertices)) + " vertices, " +
               std::to_string(py::len(r.tets)) + " tets, fields " +
               py::str(py::list(r.fields)).cast<std::string>() + ">";
      });
  py::class_<Gradient>(m, "Gradient", "Derivatives at x (Asset.grad); arrays as Mesh's.")
      .def_readonly("element", &Gradient::element)
      .def_readonly("vertices", &Gradient::vertices, "#V by 3 float32 positions at x")
      .def_readonly("dvertices", &Gradient::dvertices,
                    "K by #V by 3 float32: dvertices[d] = d vertices / d x_d")
      .def_readonly("dfields", &Gradient::dfields,
                    "{name: K blocks of the field's shape}: d field / d x_d");
  using py::arg;
  cls.def("eval", &Asset::eval, arg("x"), arg("fields") = py::none(),
          R"(The mesh and fields at x (paper Eq. 3) as a cadinterp.Mesh.
fields: None (all), a name, an index, or a sequence of them. Raises OutsideDomainError (x
outside the box or not finite), InfeasibleError, TypeError/ValueError for a malformed x.)")
      .def("eval_many", &Asset::eval_many, arg("X"), arg("fields") = py::none(), py::kw_only(),
           arg("threads") = 1, arg("errors") = "raise",
           R"(eval at each row of X (N by K), without the GIL, on `threads` threads (0: one per
core); a list of N Mesh. errors='raise' raises the first point's error (its message names the
row), errors='none' puts None where a point fails.)")
      .def("grad", &Asset::grad, arg("x"), arg("fields") = py::none(),
           "Positions and their derivatives (paper Eq. 13), and the fields' derivatives.")
      .def("vjp", &Asset::vjp, arg("x"), arg("dvertices") = py::none(), arg("dfields") = py::none(),
           R"(dF/dx (K float64) from the adjoints dF/dvertices (#V by 3) and dfields
{name or index: adjoint shaped as eval returns that field}; either may be None (zero).)")
      .def("eval_properties", &Asset::eval_properties, arg("x"), arg("density") = 1.0,
           arg("direction") = py::make_tuple(1.0, 0.0, 0.0), arg("gradient") = false,
           R"(Volume, mass, area, frontal area (along `direction`), centroid and inertia of the
solid at x; with gradient=True also {'gradient': the same keys, K derivatives each}.)")
      .def("integral", &Asset::integral, arg("x"), arg("field") = py::none(), arg("component") = 0,
           arg("region") = py::none(), arg("grad") = false,
           R"(The integral of a field's `component` over the solid at x (region None), or over a
boundary region (its name or index), as cadinterp_eval_integral: per-vertex fields integrated
piecewise-linearly, per-tet fields piecewise-constantly; field None integrates 1 (the volume, or
the region's area). A float; with grad=True (value, K float64 derivatives), exact for the mesh
(paper Eq. 13). Errors as eval, and InvalidArgumentError for a component out of range.)")
      .def("eval_outputs", &Asset::eval_outputs, arg("x"), arg("outputs") = py::none(),
           arg("grad") = false,
           R"(The per-sample scalar outputs at x (Asset.outputs), interpolated with the mesh's
basis weights without decoding a mesh (cadinterp_eval_outputs): {name: float}; with grad=True
({name: float}, {name: K float64 derivatives}), exact for the interpolant. outputs: None (all),
a name, or a sequence of names. Errors as eval, and NotFoundError for an unknown name.)");
}

}  // namespace cadinterp_py
