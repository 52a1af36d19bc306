#include "mesh/host_call.h"

#include <chrono>
#include <cmath>
#include <new>
#include <stdexcept>

#include "capi/capi_guard.h"
#include "core/grid.h"
#include "format/asset_format.h"

namespace cadinterp::mesh {

Host::Host(const cadinterp_host& h) {
  if (h.struct_size < sizeof(cadinterp_host))
    throw std::invalid_argument("host: struct_size is smaller than sizeof(cadinterp_host)");
  if (!h.regenerate) throw std::invalid_argument("host: regenerate callback is NULL");
  if (h.parameter_count < 1 || h.parameter_count > core::kMaxDim)
    throw std::invalid_argument("host: parameter_count must be 1.." +
                                std::to_string(core::kMaxDim));
  if (!h.parameters) throw std::invalid_argument("host: parameters is NULL");
  name_ = h.name ? h.name : "";
  identity_ = h.identity ? h.identity : "";
  if (name_.empty()) throw std::invalid_argument("host: name is empty");
  for (int i = 0; i < h.parameter_count; ++i) {
    const cadinterp_parameter_desc& p = h.parameters[i];
    if (!p.name || !*p.name)
      throw std::invalid_argument("host: parameter " + std::to_string(i) + " has no name");
    if (!(std::isfinite(p.lower) && std::isfinite(p.upper) && p.lower < p.upper))
      throw std::invalid_argument(std::string("host: parameter '") + p.name +
                                  "' needs finite lower < upper");
    names_.emplace_back(p.name);
    units_.emplace_back(p.unit ? p.unit : "");
    lower_.push_back(p.lower);
    upper_.push_back(p.upper);
  }
  host_ = h;
  host_.name = name_.c_str();
  host_.identity = identity_.c_str();
  host_.parameters = nullptr;  // the copies above are the ones used
}

namespace {

// A host callback's exception, as the words after the callback's name in the Sample's message:
// every exception is the host's failure at that x (the build goes on), so none is an internal
// error of the builder's, and each keeps its own words.
bool callback_exceptions(cadinterp_status* status, std::string* error) {
  *status = CADINTERP_E_INTERNAL;
  try {
    throw;
  } catch (const std::bad_alloc&) {
    if (error) *error = "ran out of memory";
  } catch (const std::exception& e) {
    if (error) *error = std::string("threw: ") + e.what();
  } catch (...) {
    if (error) *error = "threw an unknown exception";
  }
  return true;
}

// Calls one callback; a status, a C++ exception or a missing result becomes a message.
template <class F>
std::string guarded(const char* what, cadinterp_sample& out, F&& call) {
  std::string thrown;
  const cadinterp_status st = [&]() -> cadinterp_status {
    CADINTERP_CATCH_BEGIN
    return call();
    CADINTERP_CATCH_END_MAP(&thrown, callback_exceptions)
  }();
  if (!thrown.empty()) return std::string(what) + " " + thrown;
  if (st == CADINTERP_OK) return "";
  std::string m = std::string(what) + " failed (status " + std::to_string(static_cast<int>(st));
  if (st > CADINTERP_OK && st <= CADINTERP_E_INTERNAL)
    m += std::string(", ") + format::status_name(static_cast<format::Status>(st));
  m += ")";
  if (!out.sample.message.empty()) m += ": " + out.sample.message;
  return m;
}

}  // namespace

Sample Host::evaluate(const double* x) const {
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(serial_, std::defer_lock);
  if (!thread_safe()) lock.lock();
  cadinterp_sample out;
  std::string err =
      guarded("regenerate", out, [&] { return host_.regenerate(host_.user, x, &out); });
  if (err.empty() && !out.mesh_set) err = "regenerate returned OK without setting a mesh";
  if (err.empty()) {
    const std::string v = validate(out.sample);
    if (!v.empty()) err = "regenerate: " + v;
  }
  if (err.empty() && host_.references)
    err = guarded("references", out, [&] { return host_.references(host_.user, x, &out); });
  if (err.empty() && host_.simulate) err = simulate_into(x, out);
  return finish(out, err, t0);
}

Sample Host::simulate(const double* x, const Sample& mesh) const {
  const auto t0 = std::chrono::steady_clock::now();
  if (!host_.simulate) {
    Sample s;
    s.message = "the host has no simulate callback";
    return s;
  }
  std::unique_lock<std::mutex> lock(serial_, std::defer_lock);
  if (!thread_safe()) lock.lock();
  cadinterp_sample out;
  out.sample.vertices = mesh.vertices;
  out.sample.tets = mesh.tets;
  out.sample.triangles = mesh.triangles;
  out.sample.triangle_tags = mesh.triangle_tags;
  out.mesh_set = true;
  std::string err = validate(out.sample);
  if (!err.empty()) err = "the mesh to simulate on: " + err;
  if (err.empty()) err = simulate_into(x, out);
  return finish(out, err, t0);
}

std::string Host::simulate_into(const double* x, cadinterp_sample& out) const {
  const Sample& s = out.sample;
  cadinterp_host_mesh m{s.vertex_count(),      s.vertices.data(),  s.tet_count(),
                        s.tets.data(),         s.triangle_count(), s.triangles.data(),
                        s.triangle_tags.data()};
  return guarded("simulate", out, [&] { return host_.simulate(host_.user, x, &m, &out); });
}

Sample settle(Sample written, std::string err) {
  if (err.empty()) {
    const std::string v = validate(written);
    if (!v.empty()) err = "host output: " + v;
  }
  if (!err.empty()) {
    Sample failed;
    failed.message = std::move(err);
    return failed;
  }
  written.feasible = true;
  written.message.clear();
  return written;
}

Sample Host::finish(cadinterp_sample& out, std::string err,
                    std::chrono::steady_clock::time_point t0) {
  Sample s = settle(std::move(out.sample), std::move(err));
  s.host_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace cadinterp::mesh
