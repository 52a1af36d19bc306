// The builder's C ABI (include/cadinterp/cadinterp_builder.h) over build.h. Every exported body
// that can throw runs between CADINTERP_CATCH_BEGIN and CADINTERP_CATCH_END_MAP (capi_guard.h,
// with builder_exceptions): no exception crosses the interface, and failures leave outputs
// untouched.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <new>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "builder/build.h"
#include "builder/build_session.h"
#include "builder/sample_store.h"
#include "cadinterp/cadinterp_builder.h"
#include "capi/capi_guard.h"
#include "format/asset_format.h"
#include "format/asset_writer.h"
#include "mesh/host_call.h"

using cadinterp::mesh::Sample;

namespace {

thread_local std::string t_create_error;

// The builder's own exceptions, and std::invalid_argument (an inconsistent host or option), as
// statuses; out of memory and format errors are left to the shared ladder (capi_guard.h). Its
// other exceptions keep their bare what() (no "internal error: " prefix), as the builder's
// messages always have.
bool builder_exceptions(cadinterp_status* status, std::string* error) {
  try {
    throw;
  } catch (const std::bad_alloc&) {
    return false;
  } catch (const cadinterp::format::FormatError&) {
    return false;
  } catch (const cadinterp::builder::BuildCancelled& e) {
    *status = CADINTERP_E_CANCELLED;
    if (error) *error = e.what();
  } catch (const cadinterp::builder::BuildInfeasible& e) {
    *status = CADINTERP_E_INFEASIBLE;
    if (error) *error = e.what();
  } catch (const cadinterp::builder::StoreError& e) {
    *status = e.kind == cadinterp::builder::StoreError::Kind::Mismatch ? CADINTERP_E_STORE_MISMATCH
                                                                       : CADINTERP_E_IO;
    if (error) *error = e.what();
  } catch (const std::invalid_argument& e) {
    *status = CADINTERP_E_INVALID_ARGUMENT;
    if (error) *error = e.what();
  } catch (const std::exception& e) {
    *status = CADINTERP_E_INTERNAL;
    if (error) *error = e.what();
  } catch (...) {
    *status = CADINTERP_E_INTERNAL;
    if (error) *error = "unknown exception";
  }
  return true;
}

constexpr std::size_t kMaxCount = std::size_t(1) << 31;

bool valid_id(const int64_t* id, size_t n) { return id && n >= 1 && n <= 64; }

}  // namespace

struct cadinterp_builder {
  std::unique_ptr<cadinterp::mesh::Host> host;
  cadinterp::builder::BuildOptions options;
  cadinterp_progress_fn progress = nullptr;
  void* progress_user = nullptr;
  cadinterp_build_report report{};
  cadinterp::builder::BuildReport details;  // of the last run, finished or failed
  double write_seconds = 0;
  std::string error;
  bool host_on_calling_thread = false;
  bool busy = false;  // a session exists or a run is under way (either excludes the other)
};

struct cadinterp_build_session {
  cadinterp_builder* builder = nullptr;
  std::unique_ptr<cadinterp::builder::BuildSession> session;
  bool finished = false;
};

namespace {

int session_concurrency(const cadinterp_builder& b) {
  return b.options.threads > 0
             ? b.options.threads
             : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

std::unique_ptr<cadinterp::builder::BuildSession> start_session(cadinterp_builder& b) {
  return std::make_unique<cadinterp::builder::BuildSession>(*b.host, b.options,
                                                            session_concurrency(b));
}

// The end of a run or session: the build's result written to `path` (temporary name, renamed)
// and the builder's report, stages, reasons and error set from it, whatever happened.
cadinterp_status end_run(cadinterp_builder& b, cadinterp::builder::BuildSession& session,
                         const char* path) {
  b.write_seconds = 0;
  const cadinterp_status status = [&]() -> cadinterp_status {
    CADINTERP_CATCH_BEGIN
    cadinterp::builder::BuildResult r = session.finish(b.details);
    const auto t0 = std::chrono::steady_clock::now();
    cadinterp::format::write_asset_file(r.content,
                                        cadinterp::builder::asset_write_options(b.options), path);
    b.details.counts.asset_bytes = std::filesystem::file_size(path);
    b.write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    b.details.counts.wall_seconds += b.write_seconds;
    b.error.clear();
    return CADINTERP_OK;
    CADINTERP_CATCH_END_MAP(&b.error, builder_exceptions)
  }();
  b.report = b.details.counts;
  return status;
}

}  // namespace

extern "C" {

CADINTERP_API cadinterp_status cadinterp_sample_set_mesh(cadinterp_sample* s, const double* V,
                                                         size_t nv, const uint32_t* T, size_t nt,
                                                         const uint32_t* F, const int32_t* tags,
                                                         size_t nf) {
  CADINTERP_CATCH_BEGIN
  if (!s || s->mesh_set || (nv && !V) || (nt && !T) || (nf && (!F || !tags)) || nv >= kMaxCount ||
      nt >= kMaxCount || nf >= kMaxCount)
    return CADINTERP_E_INVALID_ARGUMENT;
  // Copied aside first: running out of memory halfway leaves the sample as it was.
  std::vector<double> vertices(V, V + 3 * nv);
  std::vector<uint32_t> tets(T, T + 4 * nt), triangles(F, F + 3 * nf);
  std::vector<int32_t> triangle_tags(tags, tags + nf);
  Sample& x = s->sample;
  x.vertices = std::move(vertices);
  x.tets = std::move(tets);
  x.triangles = std::move(triangles);
  x.triangle_tags = std::move(triangle_tags);
  s->mesh_set = true;
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_add_point(cadinterp_sample* s, const int64_t* id,
                                                          size_t n, const double* position) {
  CADINTERP_CATCH_BEGIN
  if (!s || !valid_id(id, n) || !position) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp::mesh::ControlPoint p;
  p.id.assign(id, id + n);
  for (const auto& q : s->sample.points)
    if (q.id == p.id) return CADINTERP_E_INVALID_ARGUMENT;
  std::memcpy(p.position, position, sizeof p.position);
  s->sample.points.push_back(std::move(p));
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_add_path(cadinterp_sample* s, const int64_t* a,
                                                         size_t na, const int64_t* b, size_t nb,
                                                         const double* polyline, size_t np) {
  CADINTERP_CATCH_BEGIN
  if (!s || !valid_id(a, na) || !valid_id(b, nb) || !polyline || np < 2 || np >= kMaxCount)
    return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp::mesh::Path p;
  p.a.assign(a, a + na);
  p.b.assign(b, b + nb);
  p.polyline.assign(polyline, polyline + 3 * np);
  s->sample.paths.push_back(std::move(p));
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_add_region(cadinterp_sample* s, const char* name,
                                                           const char* kind, const int32_t* tags,
                                                           size_t n) {
  CADINTERP_CATCH_BEGIN
  if (!s || !name || !*name || (n && !tags) || n >= kMaxCount) return CADINTERP_E_INVALID_ARGUMENT;
  for (const auto& r : s->sample.regions)
    if (r.name == name) return CADINTERP_E_INVALID_ARGUMENT;
  s->sample.regions.push_back({name, kind ? kind : "", std::vector<int32_t>(tags, tags + n)});
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_add_field(cadinterp_sample* s, const char* name,
                                                          cadinterp_field_location loc,
                                                          int components, const double* values,
                                                          size_t count) {
  CADINTERP_CATCH_BEGIN
  if (!s || !name || !*name || components < 1 || components > 16 ||
      (loc != CADINTERP_PER_VERTEX && loc != CADINTERP_PER_TET) || (count && !values) ||
      count >= kMaxCount)
    return CADINTERP_E_INVALID_ARGUMENT;
  for (const auto& f : s->sample.fields)
    if (f.name == name) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp::mesh::Field f;
  f.name = name;
  f.location = static_cast<std::uint8_t>(loc);
  f.components = components;
  f.values.assign(values, values + count * static_cast<std::size_t>(components));
  s->sample.fields.push_back(std::move(f));
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_set_field_unit(cadinterp_sample* s,
                                                               const char* name, const char* unit) {
  CADINTERP_CATCH_BEGIN
  if (!s || !name || !*name || !unit) return CADINTERP_E_INVALID_ARGUMENT;
  for (auto& f : s->sample.fields)
    if (f.name == name) {
      f.unit = unit;
      return CADINTERP_OK;
    }
  return CADINTERP_E_NOT_FOUND;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_add_output(cadinterp_sample* s, const char* name,
                                                           double value, const char* unit) {
  CADINTERP_CATCH_BEGIN
  if (!s || !name || !*name) return CADINTERP_E_INVALID_ARGUMENT;
  for (const auto& o : s->sample.outputs)
    if (o.name == name) return CADINTERP_E_INVALID_ARGUMENT;
  s->sample.outputs.push_back({name, value, unit ? unit : ""});
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_sample_set_message(cadinterp_sample* s,
                                                            const char* message) {
  CADINTERP_CATCH_BEGIN
  if (!s || !message) return CADINTERP_E_INVALID_ARGUMENT;
  s->sample.message = message;
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

// Worker side of a session driver: the same guarded, validated call as the builder's own
// threads make (mesh::Host), its Sample serialized. A per-call Host copy is cheap (strings and
// the parameter box) and keeps the function free of state.
namespace {
cadinterp_status serialized_result(const Sample& sample, void** bytes, size_t* size) {
  const std::vector<std::uint8_t> b = cadinterp::mesh::serialize(sample);
  void* out = std::malloc(b.empty() ? 1 : b.size());
  if (!out) return CADINTERP_E_OUT_OF_MEMORY;
  if (!b.empty()) std::memcpy(out, b.data(), b.size());
  *bytes = out;
  *size = b.size();
  return CADINTERP_OK;
}
}  // namespace

CADINTERP_API cadinterp_status cadinterp_host_evaluate_serialized(const cadinterp_host* host,
                                                                  const double* x, void** bytes,
                                                                  size_t* size) {
  CADINTERP_CATCH_BEGIN
  if (!host || !x || !bytes || !size) return CADINTERP_E_INVALID_ARGUMENT;
  const cadinterp::mesh::Host h(*host);
  return serialized_result(h.evaluate(x), bytes, size);
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_host_simulate_serialized(const cadinterp_host* host,
                                                                  const double* x,
                                                                  const cadinterp_host_mesh* mesh,
                                                                  void** bytes, size_t* size) {
  CADINTERP_CATCH_BEGIN
  if (!host || !x || !mesh || !bytes || !size) return CADINTERP_E_INVALID_ARGUMENT;
  if ((mesh->vertex_count && !mesh->vertices) || (mesh->tet_count && !mesh->tets) ||
      (mesh->triangle_count && (!mesh->triangles || !mesh->triangle_tags)) ||
      mesh->vertex_count >= kMaxCount || mesh->tet_count >= kMaxCount ||
      mesh->triangle_count >= kMaxCount)
    return CADINTERP_E_INVALID_ARGUMENT;
  const cadinterp::mesh::Host h(*host);
  Sample m;
  m.feasible = true;
  m.vertices.assign(mesh->vertices, mesh->vertices + 3 * mesh->vertex_count);
  m.tets.assign(mesh->tets, mesh->tets + 4 * mesh->tet_count);
  m.triangles.assign(mesh->triangles, mesh->triangles + 3 * mesh->triangle_count);
  m.triangle_tags.assign(mesh->triangle_tags, mesh->triangle_tags + mesh->triangle_count);
  return serialized_result(h.simulate(x, m), bytes, size);
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API void cadinterp_bytes_free(void* bytes) { std::free(bytes); }

CADINTERP_API const char* cadinterp_builder_version(void) {
#define CADINTERP_BUILDER_STR2(x) #x
#define CADINTERP_BUILDER_STR(x) CADINTERP_BUILDER_STR2(x)
  return CADINTERP_BUILDER_STR(CADINTERP_VERSION_MAJOR) "." CADINTERP_BUILDER_STR(
      CADINTERP_VERSION_MINOR) "." CADINTERP_BUILDER_STR(CADINTERP_VERSION_PATCH);
#undef CADINTERP_BUILDER_STR
#undef CADINTERP_BUILDER_STR2
}

CADINTERP_API unsigned cadinterp_builder_version_number(void) { return CADINTERP_VERSION_NUMBER; }

CADINTERP_API void cadinterp_build_options_init(cadinterp_build_options* o) {
  if (!o) return;
  std::memset(o, 0, sizeof *o);
  o->struct_size = sizeof *o;
  o->degree = 1;
  o->geometry_tolerance = 1e-3;
  o->field_tolerance = 1e-2;
  o->max_samples = 256;
  o->max_depth = 8;
  o->canonical_refinement = 3;
  o->infeasible_call_fraction = 0.25;
}

CADINTERP_API cadinterp_status cadinterp_builder_create(const cadinterp_host* host,
                                                        const cadinterp_build_options* options,
                                                        cadinterp_builder** out) {
  // Every failure leaves *out NULL (the header's promise), so a caller that destroys it
  // unconditionally never frees a stale pointer.
  if (out) *out = nullptr;
  CADINTERP_CATCH_BEGIN
  if (!out) throw std::invalid_argument("out is NULL");
  if (!host) throw std::invalid_argument("host is NULL");
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  if (options) {
    // Grow-by-addition: a caller compiled against an older, shorter struct still works.
    if (options->struct_size < offsetof(cadinterp_build_options, progress_user) + sizeof(void*))
      throw std::invalid_argument("options: struct_size too small");
    std::memcpy(&o, options, std::min(options->struct_size, sizeof o));
  }
  if (o.degree != 1 && o.degree != 3) throw std::invalid_argument("options: degree must be 1 or 3");
  auto b = std::make_unique<cadinterp_builder>();
  b->host = std::make_unique<cadinterp::mesh::Host>(*host);
  auto& bo = b->options;
  bo.degree = o.degree == 3 ? cadinterp::core::Degree::Cubic : cadinterp::core::Degree::Linear;
  bo.geometry_tolerance = o.geometry_tolerance;
  bo.field_tolerance = o.field_tolerance;
  bo.max_samples = o.max_samples;
  bo.max_depth = o.max_depth;
  bo.threads = o.threads;
  bo.store_path = o.store_path ? o.store_path : "";
  bo.position_max_abs_error = o.position_max_abs_error;
  bo.simulate_mapped = o.simulate_mapped != 0;
  bo.canonical_refinement = o.canonical_refinement;
  bo.infeasible_call_fraction = o.infeasible_call_fraction;
  bo.lazy_face_centres = o.lazy_face_centres != 0;
  bo.calibration_points = o.calibration_points;
  bo.map_cache_bytes = static_cast<std::size_t>(
      std::min<std::uint64_t>(o.map_cache_bytes, std::numeric_limits<std::size_t>::max()));
  if (!std::isfinite(bo.infeasible_call_fraction))
    throw std::invalid_argument("options: infeasible_call_fraction must be finite");
  if (bo.canonical_refinement < 0 || bo.canonical_refinement > 20)
    throw std::invalid_argument("options: canonical_refinement must be 0..20");
  if (!(bo.geometry_tolerance > 0) || !(bo.field_tolerance > 0))
    throw std::invalid_argument("options: tolerances must be positive");
  if (bo.max_samples < 2) throw std::invalid_argument("options: max_samples must be >= 2");
  if (bo.max_depth < 1 || bo.max_depth > 29)
    throw std::invalid_argument("options: max_depth must be 1..29");
  if (bo.threads < 0) throw std::invalid_argument("options: threads must be >= 0");
  // Checked again by the build; refused here so that create reports every inconsistent
  // option, as its header says, before any run.
  if (!(bo.position_max_abs_error >= 0))
    throw std::invalid_argument("options: position_max_abs_error must be >= 0");
  if (bo.calibration_points < 0 || bo.calibration_points > CADINTERP_MAX_CALIBRATION_POINTS)
    throw std::invalid_argument("options: calibration_points must be 0.." +
                                std::to_string(CADINTERP_MAX_CALIBRATION_POINTS));
  if (bo.simulate_mapped && !host->simulate)
    throw std::invalid_argument("options: simulate_mapped needs a host with a simulate callback");
  b->host_on_calling_thread = o.host_on_calling_thread != 0;
  b->progress = o.progress;
  b->progress_user = o.progress_user;
  if (b->progress) {
    cadinterp_builder* raw = b.get();
    bo.progress = [raw](const cadinterp_progress& p) {
      return raw->progress(raw->progress_user, &p) != 0;
    };
  }
  *out = b.release();
  t_create_error.clear();
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(&t_create_error, builder_exceptions)
}

CADINTERP_API const char* cadinterp_builder_create_error(void) { return t_create_error.c_str(); }

CADINTERP_API const char* cadinterp_builder_open_error(void) {
  return cadinterp_builder_create_error();
}

CADINTERP_API void cadinterp_builder_destroy(cadinterp_builder* b) { delete b; }

CADINTERP_API cadinterp_status cadinterp_builder_run(cadinterp_builder* b, const char* path) {
  if (!b) return CADINTERP_E_INVALID_ARGUMENT;
  if (b->busy) {
    b->error = "a build session is active on this builder";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  b->details = cadinterp::builder::BuildReport{};
  b->write_seconds = 0;
  std::unique_ptr<cadinterp::builder::BuildSession> session;
  const cadinterp_status started = [&]() -> cadinterp_status {
    CADINTERP_CATCH_BEGIN
    if (!path || !*path) throw std::invalid_argument("output path is NULL or empty");
    cadinterp::format::check_asset_file_writable(path);
    session = start_session(*b);
    return CADINTERP_OK;
    CADINTERP_CATCH_END_MAP(&b->error, builder_exceptions)
  }();
  if (started != CADINTERP_OK) {
    b->report = b->details.counts;
    return started;
  }
  // The run is a driver over the session: the host on worker threads, or on this thread.
  b->busy = true;
  const cadinterp_status driven = [&]() -> cadinterp_status {
    CADINTERP_CATCH_BEGIN
    if (b->host_on_calling_thread)
      cadinterp::builder::drive_on_calling_thread(*session, *b->host);
    else
      cadinterp::builder::drive_with_threads(*session, *b->host, session_concurrency(*b));
    return CADINTERP_OK;
    CADINTERP_CATCH_END_MAP(&b->error, builder_exceptions)
  }();
  const std::string drive_error = b->error;
  cadinterp_status status = end_run(*b, *session, path);
  if (driven != CADINTERP_OK) {  // the driver's own failure (out of memory) cancelled the build
    status = driven;
    b->error = drive_error;
  }
  session.reset();
  b->busy = false;
  return status;
}

CADINTERP_API cadinterp_status cadinterp_builder_report(const cadinterp_builder* b,
                                                        cadinterp_build_report* out) {
  if (!b || !out || out->struct_size < sizeof(size_t)) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp_build_report r = b->report;
  r.struct_size = std::min(out->struct_size, sizeof r);
  std::memcpy(out, &r, r.struct_size);
  return CADINTERP_OK;
}

CADINTERP_API cadinterp_status cadinterp_builder_stages(const cadinterp_builder* b,
                                                        cadinterp_build_stages* out) {
  if (!b || !out || out->struct_size < sizeof(size_t)) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp_build_stages s;
  std::memset(&s, 0, sizeof s);
  s.struct_size = std::min(out->struct_size, sizeof s);
  const cadinterp::builder::BuildReport& d = b->details;
  s.points_requested = d.points_requested;
  s.infeasible_reasons = static_cast<int>(d.infeasible_reasons.size());
  s.other_infeasible_points = d.other_infeasible_points;
  s.store_seconds = d.store_seconds;
  s.sampling_seconds = d.sampling_seconds;
  s.refinement_seconds = d.refinement_seconds;
  s.elements_seconds = d.elements_seconds;
  s.write_seconds = b->write_seconds;
  s.unmapped_elements = d.unmapped_elements;
  s.mapped_simulated = d.mapped_simulated;
  s.mapped_simulate_failures = d.mapped_simulate_failures;
  s.first_mapped_simulate_failure = d.first_mapped_simulate_failure.c_str();
  s.refined_elements = d.refined_elements;
  s.refined_vertices = d.refined_vertices;
  s.infeasible_splits = d.infeasible_splits;
  s.interior_unsplit = d.interior_unsplit;
  s.bound_unsplit = d.bound_unsplit;
  s.maps = d.maps;
  s.maps_again = d.maps_again;
  s.unmapped_fallbacks = d.unmapped_fallbacks;
  s.calibrated_points = d.calibrated_points;
  s.calibration_count = static_cast<int>(d.calibration.size());
  s.calibration = d.calibration.empty() ? nullptr : d.calibration.data();
  s.calibration_floors = d.calibration_floors.empty() ? nullptr : d.calibration_floors.data();
  std::memcpy(out, &s, s.struct_size);
  return CADINTERP_OK;
}

CADINTERP_API cadinterp_status cadinterp_builder_infeasible_reason(const cadinterp_builder* b,
                                                                   int index, const char** message,
                                                                   int* count) {
  if (!b || index < 0 || static_cast<std::size_t>(index) >= b->details.infeasible_reasons.size())
    return CADINTERP_E_INVALID_ARGUMENT;
  const auto& r = b->details.infeasible_reasons[static_cast<std::size_t>(index)];
  if (message) *message = r.message.c_str();
  if (count) *count = r.count;
  return CADINTERP_OK;
}

CADINTERP_API const char* cadinterp_builder_error(const cadinterp_builder* b) {
  return b ? b->error.c_str() : "builder is NULL";
}

CADINTERP_API cadinterp_status cadinterp_build_session_create(cadinterp_builder* b,
                                                              cadinterp_build_session** out) {
  if (out) *out = nullptr;
  if (!b || !out) return CADINTERP_E_INVALID_ARGUMENT;
  if (b->busy) {
    b->error = "a build session is active on this builder";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  b->details = cadinterp::builder::BuildReport{};
  b->write_seconds = 0;
  const cadinterp_status status = [&]() -> cadinterp_status {
    CADINTERP_CATCH_BEGIN
    auto s = std::make_unique<cadinterp_build_session>();
    s->builder = b;
    s->session = start_session(*b);
    *out = s.release();
    b->busy = true;
    b->error.clear();
    return CADINTERP_OK;
    CADINTERP_CATCH_END_MAP(&b->error, builder_exceptions)
  }();
  b->report = b->details.counts;
  return status;
}

CADINTERP_API cadinterp_status
cadinterp_build_session_next_requests(cadinterp_build_session* s, cadinterp_build_request* requests,
                                      size_t capacity, int timeout_ms, size_t* count, int* done) {
  CADINTERP_CATCH_BEGIN
  if (!s || !count || !done || (capacity && !requests)) return CADINTERP_E_INVALID_ARGUMENT;
  std::vector<cadinterp::builder::BuildSession::Request> got(std::min<size_t>(capacity, 1024));
  bool finished = false;
  const size_t n = s->session->next_requests(got.data(), got.size(), timeout_ms, finished);
  for (size_t i = 0; i < n; ++i) requests[i] = got[i].c;
  *count = n;
  *done = finished ? 1 : 0;
  if (s->session->report_progress()) *done = 1;
  return CADINTERP_OK;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_build_session_sample(cadinterp_build_session* s,
                                                              uint64_t id, cadinterp_sample** out) {
  if (!s || !out) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp_sample* found = s->session->sample(id);
  if (!found) return CADINTERP_E_NOT_FOUND;
  *out = found;
  return CADINTERP_OK;
}

CADINTERP_API cadinterp_status cadinterp_build_session_submit(cadinterp_build_session* s,
                                                              uint64_t id,
                                                              cadinterp_status host_status) {
  CADINTERP_CATCH_BEGIN
  if (!s) return CADINTERP_E_INVALID_ARGUMENT;
  const cadinterp_status st = s->session->submit_written(id, host_status);
  if (st == CADINTERP_OK) s->session->report_progress();
  return st;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_build_session_submit_serialized(cadinterp_build_session* s,
                                                                         uint64_t id,
                                                                         const void* bytes,
                                                                         size_t size) {
  CADINTERP_CATCH_BEGIN
  if (!s || !bytes) return CADINTERP_E_INVALID_ARGUMENT;
  const cadinterp_status st = s->session->submit_serialized(id, bytes, size);
  if (st == CADINTERP_OK) s->session->report_progress();
  return st;
  CADINTERP_CATCH_END_MAP(nullptr, builder_exceptions)
}

CADINTERP_API cadinterp_status cadinterp_build_session_cancel(cadinterp_build_session* s) {
  if (!s) return CADINTERP_E_INVALID_ARGUMENT;
  s->session->cancel();
  return CADINTERP_OK;
}

CADINTERP_API cadinterp_status cadinterp_build_session_finish(cadinterp_build_session* s,
                                                              const char* path) {
  if (!s || !path || s->finished) return CADINTERP_E_INVALID_ARGUMENT;
  cadinterp_builder& b = *s->builder;
  // A path that cannot be written is refused before the wait, and leaves the session
  // unfinished: finish may be called again with another path.
  const cadinterp_status writable = [&]() -> cadinterp_status {
    CADINTERP_CATCH_BEGIN
    if (!*path) throw std::invalid_argument("output path is empty");
    cadinterp::format::check_asset_file_writable(path);
    return CADINTERP_OK;
    CADINTERP_CATCH_END_MAP(&b.error, builder_exceptions)
  }();
  if (writable != CADINTERP_OK) return writable;
  s->finished = true;
  return end_run(b, *s->session, path);
}

CADINTERP_API void cadinterp_build_session_destroy(cadinterp_build_session* s) {
  if (!s) return;
  cadinterp_builder& b = *s->builder;
  if (!s->finished) {
    // Abandoned: the build is cancelled, and the builder's report says what it did.
    s->session->cancel();
    try {
      s->session->finish(b.details);
    } catch (...) {
      cadinterp_status st;
      builder_exceptions(&st, &b.error);
    }
    b.report = b.details.counts;
  }
  s->session.reset();
  b.busy = false;
  delete s;
}

}  // extern "C"
