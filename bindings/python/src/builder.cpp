// cadinterp.build: runs libcadinterp_builder on a host written in Python (the protocol is in
// bindings/python/README.md; cadinterp/_host.py checks and converts what the host returns).
//
// GIL and threads: cadinterp_builder_run runs with the GIL released; the builder calls the host
// from its worker threads, and each callback takes the GIL for as long as it runs Python. With
// calling_thread=True (cadinterp_build_options::host_on_calling_thread) the callbacks run on the
// thread that called build() instead, so the GIL never crosses threads (for hosts bound to their
// thread, and to keep other Python threads' scheduling as it is). The
// progress callback runs on the thread that called build(): it takes the GIL too, runs Python's
// signal handlers there (so Ctrl-C cancels the build cleanly, after the samples in flight) and
// calls the caller's progress function. A host exception makes that x infeasible with the last
// line of its traceback as the message; a BaseException that is not an Exception
// (KeyboardInterrupt, SystemExit) cancels the build and is raised again by build().
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "cadinterp/cadinterp_builder.h"
#include "common.h"

namespace cadinterp_py {

namespace {

/// A callback's failure with its status and message, for the sample (cadinterp_sample_set_message).
struct HostFailure {
  cadinterp_status status;
  std::string message;
};

void check_sample(cadinterp_status s, const std::string& what) {
  if (s != CADINTERP_OK) throw HostFailure{s, what + " was refused: " + cadinterp_status_string(s)};
}

/// What the C host's `user` points to during one build.
struct Bridge {
  py::object host, adapter, progress;
  int k = 0;
  bool has_references = false;
  /// regenerate's mesh dict per sample, for the references callback of the same x (the
  /// protocol hands references the dict regenerate returned), with the thread that made it.
  /// Touched with the GIL only.
  struct Pending {
    py::object mesh;
    std::thread::id thread;
  };
  std::unordered_map<const cadinterp_sample*, Pending> meshes;

  /// Keeps `mesh` for references. A thread calls one sample's callbacks in turn (regenerate,
  /// then references unless the mesh was refused), so what it left before is dropped here.
  void keep_mesh(const cadinterp_sample* sample, py::object mesh) {
    if (!has_references) return;
    const std::thread::id self = std::this_thread::get_id();
    for (auto it = meshes.begin(); it != meshes.end();)
      it = it->second.thread == self ? meshes.erase(it) : std::next(it);
    meshes[sample] = Pending{std::move(mesh), self};
  }
  /// A BaseException from a callback or from progress: the build is cancelled and build()
  /// raises it.
  std::optional<py::error_already_set> pending;

  py::array_t<double> point(const double* x) const { return py::array_t<double>(k, x); }

  /// Runs `body` with the GIL and turns whatever it throws into a status for the builder.
  template <class Body>
  cadinterp_status guarded(cadinterp_sample* out, Body&& body) {
    py::gil_scoped_acquire gil;
    std::string message;
    cadinterp_status status = CADINTERP_E_INFEASIBLE;
    try {
      if (pending) throw HostFailure{CADINTERP_E_CANCELLED, "the build is being cancelled"};
      body();
      return CADINTERP_OK;
    } catch (py::error_already_set& e) {
      if (e.matches(PyExc_Exception)) {
        message = last_traceback_line(e);
      } else {
        message = "cancelled: " + last_traceback_line(e);
        status = CADINTERP_E_CANCELLED;
        if (!pending) pending = std::move(e);
      }
    } catch (const HostFailure& f) {
      status = f.status;
      message = f.message;
    } catch (const std::exception& e) {
      message = e.what();
    }
    cadinterp_sample_set_message(out, message.c_str());
    return status;
  }

  static std::string last_traceback_line(const py::error_already_set& e) {
    const py::object lines =
        py::module_::import("traceback").attr("format_exception_only")(e.type(), e.value());
    return py::str(lines[py::int_(-1)]).attr("strip")().cast<std::string>();
  }
};

extern "C" cadinterp_status regenerate_cb(void* user, const double* x, cadinterp_sample* out) {
  Bridge& b = *static_cast<Bridge*>(user);
  return b.guarded(out, [&] {
    // (mesh dict, vertices, tets, triangles, tags, outputs) in the dtypes and layout of the C
    // ABI.
    const py::tuple r = b.adapter.attr("regenerate")(b.host, b.point(x));
    const auto v = r[1].cast<CArray<double>>();
    const auto t = r[2].cast<CArray<uint32_t>>();
    const auto f = r[3].cast<CArray<uint32_t>>();
    const auto tags = r[4].cast<CArray<int32_t>>();
    check_sample(cadinterp_sample_set_mesh(out, v.data(), std::size_t(v.shape(0)), t.data(),
                                           std::size_t(t.shape(0)), f.data(), tags.data(),
                                           std::size_t(f.shape(0))),
                 "regenerate's mesh");
    for (py::handle item : r[5].cast<py::list>()) {
      const auto name = item[py::int_(0)].cast<std::string>();
      const auto unit = item[py::int_(2)].cast<std::string>();
      check_sample(cadinterp_sample_add_output(out, name.c_str(), item[py::int_(1)].cast<double>(),
                                               unit.empty() ? nullptr : unit.c_str()),
                   "regenerate's output '" + name + "'");
    }
    b.keep_mesh(out, r[0]);
  });
}

extern "C" cadinterp_status references_cb(void* user, const double* x, cadinterp_sample* out) {
  Bridge& b = *static_cast<Bridge*>(user);
  return b.guarded(out, [&] {
    py::object mesh = py::none();
    if (auto it = b.meshes.find(out); it != b.meshes.end()) {
      mesh = it->second.mesh;
      b.meshes.erase(it);
    }
    // ([(id, position)], [(id_a, id_b, polyline)], [(name, kind, face_tags)]), converted.
    const py::tuple r = b.adapter.attr("references")(b.host, b.point(x), mesh);
    std::size_t i = 0;
    for (py::handle item : r[0].cast<py::list>()) {
      const auto id = item[py::int_(0)].cast<CArray<int64_t>>();
      const auto pos = item[py::int_(1)].cast<CArray<double>>();
      check_sample(cadinterp_sample_add_point(out, id.data(), std::size_t(id.size()), pos.data()),
                   "references' point " + std::to_string(i++));
    }
    i = 0;
    for (py::handle item : r[1].cast<py::list>()) {
      const auto a = item[py::int_(0)].cast<CArray<int64_t>>();
      const auto c = item[py::int_(1)].cast<CArray<int64_t>>();
      const auto line = item[py::int_(2)].cast<CArray<double>>();
      check_sample(
          cadinterp_sample_add_path(out, a.data(), std::size_t(a.size()), c.data(),
                                    std::size_t(c.size()), line.data(), std::size_t(line.shape(0))),
          "references' path " + std::to_string(i++));
    }
    for (py::handle item : r[2].cast<py::list>()) {
      const auto name = item[py::int_(0)].cast<std::string>();
      const auto kind = item[py::int_(1)].cast<std::string>();
      const auto tags = item[py::int_(2)].cast<CArray<int32_t>>();
      check_sample(cadinterp_sample_add_region(out, name.c_str(), kind.c_str(), tags.data(),
                                               std::size_t(tags.size())),
                   "references' region '" + name + "'");
    }
  });
}

extern "C" cadinterp_status simulate_cb(void* user, const double* x,
                                        const cadinterp_host_mesh* mesh, cadinterp_sample* out) {
  Bridge& b = *static_cast<Bridge*>(user);
  return b.guarded(out, [&] {
    // Copies: the builder's mesh lives only during this call, the host may keep what it gets.
    const auto v = static_cast<py::ssize_t>(mesh->vertex_count);
    const auto t = static_cast<py::ssize_t>(mesh->tet_count);
    const auto f = static_cast<py::ssize_t>(mesh->triangle_count);
    py::dict m;
    m["vertices"] = py::array_t<double>({v, py::ssize_t{3}}, mesh->vertices);
    m["tets"] = py::array_t<uint32_t>({t, py::ssize_t{4}}, mesh->tets);
    m["triangles"] = py::array_t<uint32_t>({f, py::ssize_t{3}}, mesh->triangles);
    m["triangle_tags"] = py::array_t<int32_t>(f, mesh->triangle_tags);
    // [(name, location, components, values, rows, unit)], values flat float64.
    const py::list fields = b.adapter.attr("simulate")(b.host, b.point(x), m);
    for (py::handle item : fields) {
      const auto name = item[py::int_(0)].cast<std::string>();
      const auto location = cadinterp_field_location(item[py::int_(1)].cast<int>());
      const auto values = item[py::int_(3)].cast<CArray<double>>();
      check_sample(
          cadinterp_sample_add_field(out, name.c_str(), location, item[py::int_(2)].cast<int>(),
                                     values.data(), item[py::int_(4)].cast<std::size_t>()),
          "simulate's field '" + name + "'");
      const auto unit = item[py::int_(5)].cast<std::string>();
      if (!unit.empty())
        check_sample(cadinterp_sample_set_field_unit(out, name.c_str(), unit.c_str()),
                     "the unit of field '" + name + "'");
    }
  });
}

extern "C" int progress_cb(void* user, const cadinterp_progress* p) {
  Bridge& b = *static_cast<Bridge*>(user);
  py::gil_scoped_acquire gil;
  if (b.pending) return 1;
  try {
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    if (b.progress.is_none()) return 0;
    py::dict d;
    d["samples_done"] = p->samples_done;
    d["samples_queued"] = p->samples_queued;
    d["elements"] = p->elements;
    d["seconds"] = p->seconds;
    d["eta_seconds"] = p->eta_seconds;
    return py::bool_(b.progress(d)) ? 1 : 0;
  } catch (py::error_already_set& e) {
    b.pending = std::move(e);
    return 1;
  }
}

struct BuilderDeleter {
  void operator()(cadinterp_builder* b) const { cadinterp_builder_destroy(b); }
};

/// The report, stages and reasons of the builder's last run as a cadinterp.BuildReport.
py::object report_of(const cadinterp_builder* builder, const std::string& output) {
  cadinterp_build_report r{};
  r.struct_size = sizeof r;
  cadinterp_builder_report(builder, &r);
  cadinterp_build_stages st{};
  st.struct_size = sizeof st;
  cadinterp_builder_stages(builder, &st);
  py::dict stages;
  stages["points_requested"] = st.points_requested;
  stages["other_infeasible_points"] = st.other_infeasible_points;
  stages["store_seconds"] = st.store_seconds;
  stages["sampling_seconds"] = st.sampling_seconds;
  stages["refinement_seconds"] = st.refinement_seconds;
  stages["elements_seconds"] = st.elements_seconds;
  stages["write_seconds"] = st.write_seconds;
  stages["unmapped_elements"] = st.unmapped_elements;
  stages["mapped_simulated"] = st.mapped_simulated;
  stages["mapped_simulate_failures"] = st.mapped_simulate_failures;
  stages["first_mapped_simulate_failure"] =
      st.first_mapped_simulate_failure ? st.first_mapped_simulate_failure : "";
  stages["refined_elements"] = st.refined_elements;
  stages["refined_vertices"] = st.refined_vertices;
  stages["maps"] = st.maps;
  stages["maps_again"] = st.maps_again;
  stages["unmapped_fallbacks"] = st.unmapped_fallbacks;
  stages["calibrated_points"] = st.calibrated_points;
  py::list calibration, calibration_floors;
  for (int q = 0; st.calibration && q < st.calibration_count; ++q)
    calibration.append(st.calibration[q]);
  for (int q = 0; st.calibration_floors && q < st.calibration_count; ++q)
    calibration_floors.append(st.calibration_floors[q]);
  stages["calibration"] = calibration;
  stages["calibration_floors"] = calibration_floors;
  py::list reasons;
  for (int i = 0; i < st.infeasible_reasons; ++i) {
    const char* message = nullptr;
    int count = 0;
    if (cadinterp_builder_infeasible_reason(builder, i, &message, &count) == CADINTERP_OK)
      reasons.append(py::make_tuple(message ? message : "", count));
  }
  return py::module_::import("cadinterp._types")
      .attr("BuildReport")(
          py::arg("output") = output, py::arg("samples") = r.samples,
          py::arg("host_evaluations") = r.host_evaluations, py::arg("store_hits") = r.store_hits,
          py::arg("infeasible_points") = r.infeasible_points, py::arg("elements") = r.elements,
          py::arg("infeasible_elements") = r.infeasible_elements,
          py::arg("stored_meshes") = r.stored_meshes,
          py::arg("budget_exhausted") = r.budget_exhausted != 0, py::arg("max_error") = r.max_error,
          py::arg("host_seconds") = r.host_seconds, py::arg("wall_seconds") = r.wall_seconds,
          py::arg("asset_bytes") = r.asset_bytes, py::arg("infeasible_reasons") = reasons,
          py::arg("stages") = stages);
}

/// The C host for `bridge`, its strings kept in `strings` and `params` (create copies them).
cadinterp_host make_host(Bridge& bridge, const py::tuple& d, std::vector<std::string>& strings,
                         std::vector<cadinterp_parameter_desc>& params) {
  // d = (name, identity, [(name, lower, upper, unit)], thread_safe, has_references, has_simulate)
  const py::list plist = d[2].cast<py::list>();
  strings.reserve(2 + 2 * plist.size());  // no reallocation: the descs point into it
  strings.push_back(d[0].cast<std::string>());
  strings.push_back(d[1].cast<std::string>());
  for (py::handle p : plist) {
    strings.push_back(p[py::int_(0)].cast<std::string>());
    const char* name = strings.back().c_str();
    strings.push_back(p[py::int_(3)].cast<std::string>());
    params.push_back({name, strings.back().c_str(), p[py::int_(1)].cast<double>(),
                      p[py::int_(2)].cast<double>()});
  }
  bridge.k = static_cast<int>(params.size());
  bridge.has_references = d[4].cast<bool>();
  cadinterp_host h{};
  h.struct_size = sizeof h;
  h.name = strings[0].c_str();
  h.identity = strings[1].c_str();
  h.parameter_count = bridge.k;
  h.parameters = params.data();
  h.user = &bridge;
  h.regenerate = regenerate_cb;
  h.references = bridge.has_references ? references_cb : nullptr;
  h.simulate = d[5].cast<bool>() ? simulate_cb : nullptr;
  h.thread_safe = d[3].cast<bool>() ? 1 : 0;
  return h;
}

/// The options of build()'s keyword arguments, as cadinterp_build_options_init's defaults.
struct Options {
  cadinterp_build_options o;
  Options() { cadinterp_build_options_init(&o); }
};

py::object build(py::object host, py::object output_path, int degree, double geometry_tolerance,
                 double field_tolerance, int max_samples, int max_depth, int threads,
                 py::object store, double position_max_abs_error, bool simulate_mapped,
                 int canonical_refinement, py::object progress, bool calling_thread,
                 int calibration_points) {
  const py::object os = py::module_::import("os");
  const std::string output = py::str(os.attr("fspath")(output_path)).cast<std::string>();
  const std::string store_path =
      store.is_none() ? "" : py::str(os.attr("fspath")(store)).cast<std::string>();
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress must be callable (it gets a dict) or None");
  Bridge bridge;
  bridge.host = host;  // alive for the whole build, whatever the caller drops meanwhile
  bridge.adapter = py::module_::import("cadinterp._host");
  bridge.progress = progress;
  const py::tuple d = bridge.adapter.attr("describe")(host);
  std::vector<std::string> strings;
  std::vector<cadinterp_parameter_desc> params;
  const cadinterp_host h = make_host(bridge, d, strings, params);

  Options opt;
  opt.o.degree = degree;
  opt.o.geometry_tolerance = geometry_tolerance;
  opt.o.field_tolerance = field_tolerance;
  opt.o.max_samples = max_samples;
  opt.o.max_depth = max_depth;
  opt.o.threads = threads;
  opt.o.store_path = store_path.empty() ? nullptr : store_path.c_str();
  opt.o.position_max_abs_error = position_max_abs_error;
  opt.o.simulate_mapped = simulate_mapped ? 1 : 0;
  opt.o.canonical_refinement = canonical_refinement;
  opt.o.host_on_calling_thread = calling_thread ? 1 : 0;
  opt.o.calibration_points = calibration_points;
  opt.o.progress = progress_cb;
  opt.o.progress_user = &bridge;

  cadinterp_builder* raw = nullptr;
  cadinterp_status s = cadinterp_builder_create(&h, &opt.o, &raw);
  if (s != CADINTERP_OK) throw StatusError(s, cadinterp_builder_create_error());
  std::unique_ptr<cadinterp_builder, BuilderDeleter> builder(raw);
  {
    py::gil_scoped_release release;
    s = cadinterp_builder_run(builder.get(), output.c_str());
  }
  bridge.meshes.clear();
  if (bridge.pending) throw *bridge.pending;
  py::object report = report_of(builder.get(), output);
  if (s != CADINTERP_OK) {
    py::object err = make_error(s, cadinterp_builder_error(builder.get()));
    err.attr("report") = report;
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(err.ptr())), err.ptr());
    throw py::error_already_set();
  }
  return report;
}

}  // namespace

void init_builder(py::module_& m) {
  using py::arg;
  const Options defaults;
  const cadinterp_build_options& o = defaults.o;
  m.def("build", &build, arg("host"), arg("output_path"), py::kw_only(), arg("degree") = o.degree,
        arg("geometry_tolerance") = o.geometry_tolerance,
        arg("field_tolerance") = o.field_tolerance, arg("max_samples") = o.max_samples,
        arg("max_depth") = o.max_depth, arg("threads") = 1, arg("store") = py::none(),
        arg("position_max_abs_error") = o.position_max_abs_error,
        arg("simulate_mapped") = o.simulate_mapped != 0,
        arg("canonical_refinement") = o.canonical_refinement, arg("progress") = py::none(),
        arg("calling_thread") = o.host_on_calling_thread != 0,
        arg("calibration_points") = o.calibration_points,
        R"(Precomputes `host` (a Python host, see cadinterp.Host) into the asset `output_path`
with libcadinterp_builder and returns a cadinterp.BuildReport. The options are those of
cadinterp_build_options (cadinterp_builder.h), with its defaults but threads=1 (0: one per
core; calling_thread=True: the host only on this thread, threads ignored); store is the
sample-store file (resumable builds). progress(dict) is called after each
sample; a true return cancels. Ctrl-C cancels cleanly and raises KeyboardInterrupt. A failed
build raises the error of its status, with the BuildReport as its `report` attribute.)");
}

}  // namespace cadinterp_py
