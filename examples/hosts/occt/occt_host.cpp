// The OCCT host: options, evaluation (regenerate -> check -> mesh -> references), the FEM call,
// the builder's C callbacks and the library entry (occt_host.h).
#include "occt_host.h"

#include <BRepCheck_Analyzer.hxx>
#include <BRepGProp.hxx>
#include <GProp_GProps.hxx>
#include <Standard_Failure.hxx>
#include <TopExp_Explorer.hxx>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <set>
#include <sstream>
#include <stdexcept>

#include "occt_mesh.h"
#include "occt_models.h"
#include "occt_references.h"

#ifdef CADINTERP_OCCT_HAVE_PHYSICS
#include "physics.h"
#endif

namespace cadinterp::occt {

using Clock = std::chrono::steady_clock;
static double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Model::Impl {
  const ModelDef* def = nullptr;
  MeshSettings mesh;
  // Quadratic tets by default: linear ones lock in bending (the wrench handle's bending stress
  // 10 % low, the press spine's 30 % at the default sizes); README "Physics" has the measurement.
  int order = 2, levels = 1;
  Settings settings;
  std::string identity;
  std::vector<cadinterp_parameter_desc> params;  ///< the varied parameters
  std::vector<std::size_t> varied;               ///< their indices in the model's list
  std::vector<double> held;                      ///< every parameter; held ones at the centre
  cadinterp_host host{};

  /// The model's full parameter vector from the host's x.
  std::vector<double> full(const double* x) const {
    std::vector<double> f = held;
    for (std::size_t i = 0; i < varied.size(); ++i) f[varied[i]] = x[i];
    return f;
  }
  mutable std::mutex lock;
  mutable StageTimes times;
  /// The regions by x (the host's K values), of every successful evaluation: simulate
  /// needs nothing else besides the mesh it is handed, which need not be the one meshed here (a
  /// mapped mesh, paper §6). Under `lock`; bounded by kNamedKept.
  mutable std::map<std::vector<double>, std::shared_ptr<const Evaluation>> named;
  static constexpr std::size_t kNamedKept = 4096;

  void keep_named(const double* x, const Evaluation& e) const {
    auto n = std::make_shared<Evaluation>();
    n->ok = true;
    n->regions = e.regions;
    std::lock_guard<std::mutex> g(lock);
    if (named.size() >= kNamedKept) named.clear();
    named[std::vector<double>(x, x + params.size())] = std::move(n);
  }

  void count(const StageTimes& t) const {
    std::lock_guard<std::mutex> g(lock);
    times.regenerations += t.regenerations;
    times.failures += t.failures;
    times.regenerate += t.regenerate;
    times.tessellate += t.tessellate;
    times.tetgen += t.tetgen;
    times.references += t.references;
    times.physics += t.physics;
  }
};

namespace {

double parse_number(const std::string& key, const std::string& value, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size() || !std::isfinite(v) || v < lo ||
      v > hi) {
    std::ostringstream s;
    s << "occt host: option " << key << "='" << value << "' must be a number in [" << lo << ", "
      << hi << "]";
    throw std::invalid_argument(s.str());
  }
  return v;
}

std::string g(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

cadinterp_status host_regenerate(void* user, const double* x, cadinterp_sample* out);
cadinterp_status host_references(void* user, const double* x, cadinterp_sample* out);
cadinterp_status host_simulate(void* user, const double* x, const cadinterp_host_mesh* mesh,
                               cadinterp_sample* out);

}  // namespace

Model::Model(const std::string& model, const std::string& options) : impl_(new Impl) {
  const std::string name = model.empty() ? "wrench" : model;
  impl_->def = find_model(name);
  if (!impl_->def) {
    std::string known;
    for (const std::string& n : model_names()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("occt host: unknown model '" + name + "' (models: " + known + ")");
  }
  Impl& m = *impl_;
  m.mesh.mesh_size = m.def->default_mesh_size;
  m.settings.force = m.def->default_force;
  m.settings.heat_flux = 0.02;
  std::stringstream ss(options);
  std::string item, vary, range;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("occt host: option '" + item + "' is not key=value");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    if (key == "mesh_size")
      m.mesh.mesh_size = parse_number(key, value, 0.2, 200);
    else if (key == "order")
      m.order = static_cast<int>(parse_number(key, value, 1, 2));
    else if (key == "levels")
      m.levels = static_cast<int>(parse_number(key, value, 0, 4));
    else if (key == "keep_surface")
      m.mesh.keep_surface = parse_number(key, value, 0, 1) != 0;
    else if (key == "force")
      m.settings.force = parse_number(key, value, 1e-6, 1e9);
    else if (key == "heat_flux")
      m.settings.heat_flux = parse_number(key, value, 0, 1e3);
    else if (key == "quality")
      m.mesh.quality = parse_number(key, value, 1.05, 10);
    else if (key == "angle")
      m.mesh.angle = parse_number(key, value, 0.05, 1.5);
    else if (key == "min_angle")
      m.mesh.min_angle = parse_number(key, value, 0, 30);
    else if (key == "vary")
      vary = value;
    else if (key == "range")
      range = value;
    else
      throw std::invalid_argument(
          "occt host: unknown option '" + key +
          "' (mesh_size, order, levels, keep_surface, quality, angle, min_angle, force, heat_flux, "
          "vary, range)");
    if ((key == "order" || key == "levels" || key == "keep_surface") &&
        value.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("occt host: option " + key + " must be an integer");
  }
  // vary=a+b: only these parameters are the host's; the others stay at the box's centre (a
  // study of one effect, e.g. the load angle alone).
  std::vector<std::string> names;
  for (std::stringstream vs(vary); std::getline(vs, item, '+');)
    if (!item.empty()) names.push_back(item);
  // range=name:lo:hi+...: a parameter's range narrowed inside the model's (e.g. to keep a cubic
  // asset's B-spline supports clear of a region where the model cannot be built).
  std::vector<double> lower, upper;
  for (const ParameterDef& p : m.def->parameters) {
    lower.push_back(p.lower);
    upper.push_back(p.upper);
  }
  for (std::stringstream rs(range); std::getline(rs, item, '+');) {
    if (item.empty()) continue;
    const auto c1 = item.find(':'), c2 = item.rfind(':');
    if (c1 == std::string::npos || c1 == c2)
      throw std::invalid_argument("occt host: range wants name:lower:upper, got '" + item + "'");
    const std::string n = item.substr(0, c1);
    std::size_t i = 0;
    while (i < m.def->parameters.size() && m.def->parameters[i].name != n) ++i;
    if (i == m.def->parameters.size())
      throw std::invalid_argument("occt host: range names an unknown parameter '" + n + "' of " +
                                  m.def->name);
    const ParameterDef& p = m.def->parameters[i];
    lower[i] = parse_number("range " + n, item.substr(c1 + 1, c2 - c1 - 1), p.lower, p.upper);
    upper[i] = parse_number("range " + n, item.substr(c2 + 1), p.lower, p.upper);
    if (!(lower[i] < upper[i]))
      throw std::invalid_argument("occt host: range of " + n + " is empty: '" + item + "'");
  }
  for (std::size_t i = 0; i < m.def->parameters.size(); ++i) {
    const ParameterDef& p = m.def->parameters[i];
    m.held.push_back(0.5 * (lower[i] + upper[i]));
    if (names.empty() || std::find(names.begin(), names.end(), p.name) != names.end())
      m.varied.push_back(i);
  }
  for (const std::string& n : names) {
    bool known = false;
    for (const ParameterDef& p : m.def->parameters) known = known || p.name == n;
    if (!known)
      throw std::invalid_argument("occt host: vary names an unknown parameter '" + n + "' of " +
                                  m.def->name);
  }
  m.identity = "occt " + m.def->name + " v" + std::to_string(m.def->version) +
               " (mesh_size=" + g(m.mesh.mesh_size) + ", order=" + std::to_string(m.order) +
               ", levels=" + std::to_string(m.levels) +
               ", keep_surface=" + (m.mesh.keep_surface ? "1" : "0") +
               ", quality=" + g(m.mesh.quality) + ", angle=" + g(m.mesh.angle) +
               ", min_angle=" + g(m.mesh.min_angle) + ", force=" + g(m.settings.force) +
               (m.def->name == "hub" ? ", heat_flux=" + g(m.settings.heat_flux) : "") +
               (names.empty() ? std::string() : ", vary=" + vary) +
               (range.empty() ? std::string() : ", range=" + range) + ")" +
               // The fields' definition: v3 recovers the vertex stresses by L2 projection
               // (examples/physics); outputs v1 are brep_volume and max_von_mises. Stores of
               // other definitions are refused.
               " fields v3 (stress=l2-projection), outputs v1";
  for (std::size_t i : m.varied) {
    const ParameterDef& p = m.def->parameters[i];
    m.params.push_back({p.name.c_str(), p.unit.c_str(), lower[i], upper[i]});
  }
  m.host.struct_size = sizeof(cadinterp_host);
  m.host.name = "occt";
  m.host.identity = m.identity.c_str();
  m.host.parameter_count = static_cast<int>(m.params.size());
  m.host.parameters = m.params.data();
  m.host.user = this;
  m.host.regenerate = host_regenerate;
  m.host.references = host_references;
  m.host.simulate = has_physics() ? host_simulate : nullptr;
  // OCCT's modelling algorithms and BRepMesh work on per-call shapes; TetGen is serialized
  // inside mesh_shape, the FEM holds no global state.
  m.host.thread_safe = 1;
}

Model::~Model() = default;

const std::string& Model::name() const { return impl_->def->name; }
const std::string& Model::identity() const { return impl_->identity; }
int Model::parameter_count() const { return static_cast<int>(impl_->params.size()); }
const cadinterp_parameter_desc* Model::parameters() const { return impl_->params.data(); }
std::vector<double> Model::center() const {
  std::vector<double> c;
  for (const auto& p : impl_->params) c.push_back(0.5 * (p.lower + p.upper));
  return c;
}
const cadinterp_host* Model::host() const { return &impl_->host; }
bool Model::thermal() const { return impl_->def->name == "hub"; }

bool Model::has_physics() {
#ifdef CADINTERP_OCCT_HAVE_PHYSICS
  return true;
#else
  return false;
#endif
}

StageTimes Model::stage_times() const {
  std::lock_guard<std::mutex> l(impl_->lock);
  return impl_->times;
}
void Model::reset_stage_times() const {
  std::lock_guard<std::mutex> l(impl_->lock);
  impl_->times = StageTimes{};
}

namespace {

// OCCT 7.6's fillet and blend code keeps static state: two regenerations running at once gave
// an invalid solid now and then (seen in 2-thread builds of the wrench), so the modelling stage
// runs one at a time. Tessellation, TetGen (itself serialized) and the FEM still overlap.
std::mutex g_modelling_lock;

// Regenerates the solid and checks it (the stage that can fail for geometric reasons).
NamedShape regenerate_checked(const ModelDef& def, const double* x) {
  std::lock_guard<std::mutex> lock(g_modelling_lock);
  NamedShape s = def.build(x);
  int solids = 0;
  for (TopExp_Explorer ex(s.shape, TopAbs_SOLID); ex.More(); ex.Next()) ++solids;
  if (solids != 1)
    throw Infeasible("the features gave " + std::to_string(solids) + " solids instead of one");
  BRepCheck_Analyzer check(s.shape);
  if (!check.IsValid()) throw Infeasible("the regenerated solid is invalid (BRepCheck_Analyzer)");
  return s;
}

double volume_of(const TopoDS_Shape& s) {
  std::lock_guard<std::mutex> lock(g_modelling_lock);
  GProp_GProps props;
  BRepGProp::VolumeProperties(s, props);
  return props.Mass();
}

std::string failure_text(const Standard_Failure& f) {
  const char* msg = f.GetMessageString();
  return std::string("OCCT ") + f.DynamicType()->Name() +
         (msg && *msg ? std::string(": ") + msg : "");
}

}  // namespace

namespace {

// The B-rep's face tags and labels and the model's named regions on them.
void name_faces(const NamedShape& s, const ModelDef& def, Evaluation& e) {
  for (FaceNameMap::Iterator it(s.faces); it.More(); it.Next())
    e.faces.emplace_back(face_tag(it.Value().label), it.Value().label);
  std::sort(e.faces.begin(), e.faces.end());
  for (const RegionDef& r : def.regions) {
    Region region{r.name, r.kind, {}};
    for (FaceNameMap::Iterator it(s.faces); it.More(); it.Next())
      for (const std::string& root : it.Value().roots)
        if (std::find(r.roots.begin(), r.roots.end(), root) != r.roots.end())
          region.tags.push_back(face_tag(it.Value().label));
    std::sort(region.tags.begin(), region.tags.end());
    region.tags.erase(std::unique(region.tags.begin(), region.tags.end()), region.tags.end());
    if (region.tags.empty()) throw Infeasible("region '" + r.name + "' lost all its faces");
    e.regions.push_back(std::move(region));
  }
}

// Regenerates the model at x and names its faces; with `mesh`, also its volumes, the tet mesh
// and the references (Model::evaluate), else only the regions (Model::named).
Evaluation regenerate(const Model::Impl& m, const double* x, bool mesh) {
  Evaluation e;
  StageTimes t;
  t.regenerations = 1;
  for (int i = 0; i < static_cast<int>(m.params.size()); ++i) {
    const auto& p = m.params[static_cast<std::size_t>(i)];
    const double slack = 1e-9 * (p.upper - p.lower);
    if (!std::isfinite(x[i]) || x[i] < p.lower - slack || x[i] > p.upper + slack) {
      e.message = std::string("parameter ") + p.name + " = " + g(x[i]) + " is outside [" +
                  g(p.lower) + ", " + g(p.upper) + "]";
      t.failures = 1;
      m.count(t);
      return e;
    }
  }
  const char* stage = "regenerate";
  try {
    auto t0 = Clock::now();
    const NamedShape s = regenerate_checked(*m.def, m.full(x).data());
    if (mesh) e.exact_volume = volume_of(s.shape);
    t.regenerate = since(t0);

    if (mesh) {
      stage = "mesh";
      MeshTimes mt;
      TetMeshData tets = mesh_shape(s, m.mesh, mt);
      t.tessellate = mt.tessellate;
      t.tetgen = mt.tetgen;
      e.mesh_volume = mesh_volume(tets);
      e.vertices = std::move(tets.vertices);
      e.tets = std::move(tets.tets);
      e.triangles = std::move(tets.triangles);
      e.triangle_tags = std::move(tets.triangle_tags);
    }

    stage = "references";
    t0 = Clock::now();
    if (mesh) add_references(s, m.levels, e.points, e.paths);
    name_faces(s, *m.def, e);
    if (!mesh) e.faces.clear();  // as the ones kept by x
    t.references = since(t0);
    e.ok = true;
  } catch (const Infeasible& ex) {
    e.message = ex.what();
  } catch (const Standard_Failure& ex) {
    e.message = std::string(stage) + ": " + failure_text(ex);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& ex) {
    e.message = std::string(stage) + ": " + ex.what();
  }
  if (!e.ok) {
    Evaluation failed;
    failed.message = std::move(e.message);
    e = std::move(failed);
    t.failures = 1;
  }
  m.count(t);
  if (e.ok) m.keep_named(x, e);
  return e;
}

}  // namespace

Evaluation Model::evaluate(const double* x) const { return regenerate(*impl_, x, true); }

std::shared_ptr<const Evaluation> Model::named(const double* x) const {
  {
    std::lock_guard<std::mutex> l(impl_->lock);
    const auto it = impl_->named.find(std::vector<double>(x, x + parameter_count()));
    if (it != impl_->named.end()) return it->second;
  }
  return std::make_shared<const Evaluation>(regenerate(*impl_, x, false));
}

double Model::exact_volume(const double* x) const {
  try {
    return volume_of(regenerate_checked(*impl_->def, impl_->full(x).data()).shape);
  } catch (const Standard_Failure& ex) {
    throw std::runtime_error(failure_text(ex));
  }
}

#ifdef CADINTERP_OCCT_HAVE_PHYSICS
namespace {

// The applied surface traction as a per-vertex field (#V by 3), from exactly the loads handed to
// the FEM (examples/physics/physics_solve.cpp): a Force is its total spread uniformly over the
// region's area, F / A; a Pressure p is -p n on each triangle (positive pushes into the solid).
// Per vertex: the area-weighted mean over the loaded triangles around it, so that every vertex of
// a uniformly loaded region carries exactly F / A and the explorer's area-weighted mean over the
// region's faces gives the applied load back.
std::vector<double> traction_field(
    const Evaluation& e, const LoadCase& c,
    const std::function<std::vector<std::int32_t>(const std::string&)>& tags_of) {
  const std::size_t nv = e.vertices.size() / 3, nf = e.triangles.size() / 3;
  std::vector<double> face_t(3 * nf, 0.0), face_area(nf, 0.0), face_n(3 * nf, 0.0);
  std::vector<std::uint8_t> loaded(nf, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const double* a = &e.vertices[3 * e.triangles[3 * f]];
    const double* b = &e.vertices[3 * e.triangles[3 * f + 1]];
    const double* d = &e.vertices[3 * e.triangles[3 * f + 2]];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    face_area[f] = 0.5 * len;
    for (int i = 0; i < 3; ++i)
      face_n[3 * f + static_cast<std::size_t>(i)] = len > 0 ? n[i] / len : 0;
  }
  auto faces_of = [&](const std::string& region) {
    const std::vector<std::int32_t> t = tags_of(region);
    const std::set<std::int32_t> s(t.begin(), t.end());
    std::vector<std::size_t> out;
    for (std::size_t f = 0; f < nf; ++f)
      if (s.count(e.triangle_tags[f])) out.push_back(f);
    return out;
  };
  for (const auto& force : c.forces) {
    const std::vector<std::size_t> faces = faces_of(force.region);
    double area = 0;
    for (std::size_t f : faces) area += face_area[f];
    if (!(area > 0)) continue;  // the FEM refuses it with its own message
    for (std::size_t f : faces) {
      loaded[f] = 1;
      for (std::size_t i = 0; i < 3; ++i) face_t[3 * f + i] += force.force[i] / area;
    }
  }
  for (const auto& p : c.pressures)
    for (std::size_t f : faces_of(p.region)) {
      if (face_area[f] == 0) continue;
      loaded[f] = 1;
      for (std::size_t i = 0; i < 3; ++i) face_t[3 * f + i] -= p.pressure * face_n[3 * f + i];
    }
  std::vector<double> t(3 * nv, 0.0), w(nv, 0.0);
  for (std::size_t f = 0; f < nf; ++f) {
    if (!loaded[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const std::size_t vtx = e.triangles[3 * f + static_cast<std::size_t>(k)];
      w[vtx] += face_area[f];
      for (std::size_t i = 0; i < 3; ++i) t[3 * vtx + i] += face_area[f] * face_t[3 * f + i];
    }
  }
  for (std::size_t v = 0; v < nv; ++v)
    if (w[v] > 0)
      for (std::size_t i = 0; i < 3; ++i) t[3 * v + i] /= w[v];
  return t;
}

}  // namespace
#endif

Fields Model::simulate(const double* x, const Evaluation& e) const {
#ifdef CADINTERP_OCCT_HAVE_PHYSICS
  if (!e.ok) throw std::runtime_error("simulate: the evaluation failed: " + e.message);
  const Impl& m = *impl_;
  const auto t0 = Clock::now();
  physics::Problem p;
  p.mesh.vertices = e.vertices;
  p.mesh.tets = e.tets;
  p.mesh.triangles = e.triangles;
  p.mesh.triangle_tags = e.triangle_tags;
  p.order = m.order;
  // Steel in mm, N, MPa, W, K: E 210 GPa, conductivity 50 W/(m K) = 0.05 W/(mm K).
  p.material.youngs_modulus = 210e3;
  p.material.poisson_ratio = 0.3;
  p.material.conductivity = 0.05;
  p.material.thermal_expansion = 12e-6;
  const LoadCase c = m.def->loads(m.full(x).data(), m.settings);
  p.material.reference_temperature = c.reference_temperature;
  p.thermal = c.thermal;
  auto tags = [&](const std::string& region) {
    for (const Region& r : e.regions)
      if (r.name == region) return r.tags;
    throw std::runtime_error("simulate: no region '" + region + "'");
  };
  for (const auto& f : c.fixed) p.fixed.push_back({tags(f.region), {true, true, true}});
  for (const auto& f : c.forces)
    p.forces.push_back({tags(f.region), {f.force[0], f.force[1], f.force[2]}});
  for (const auto& f : c.pressures) p.pressures.push_back({tags(f.region), f.pressure});
  for (const auto& f : c.fluxes) p.heat_fluxes.push_back({tags(f.region), f.flux});
  for (const auto& f : c.convections)
    p.convections.push_back({tags(f.region), f.coefficient, f.ambient});
  for (const auto& f : c.temperatures) p.temperatures.push_back({tags(f.region), f.temperature});
  const physics::Solution s = physics::solve(p);
  Fields out;
  out.von_mises = s.von_mises;
  out.displacement = s.displacement;
  out.temperature = s.temperature;
  out.traction = traction_field(e, c, tags);
  StageTimes t;
  t.physics = since(t0);
  m.count(t);
  return out;
#else
  (void)x;
  (void)e;
  throw std::runtime_error("simulate: this build has no FEM (examples/physics)");
#endif
}

std::vector<std::string> model_names() {
  std::vector<std::string> n;
  for (const ModelDef& d : models()) n.push_back(d.name);
  return n;
}

// ---- the C callbacks ------------------------------------------------------------------------

namespace {

// The builder calls regenerate, references and simulate for one x with one sample in turn: the
// evaluation is kept between the first two, keyed by the sample (and checked against model and
// x; a miss just evaluates again); simulate needs only the regions (Model::named). No thread_local:
// a dlopen'd library's TLS outlives its unloading, and LeakSanitizer reports it.
struct Cached {
  const Model* model = nullptr;
  std::vector<double> x;
  std::shared_ptr<const Evaluation> e;
};
std::mutex g_cache_lock;
std::map<const cadinterp_sample*, Cached>& cache() {
  static std::map<const cadinterp_sample*, Cached> c;
  return c;
}

std::shared_ptr<const Evaluation> evaluation(const Model* m, const double* x,
                                             const cadinterp_sample* sample, bool last) {
  const std::vector<double> key(x, x + m->parameter_count());
  {
    std::lock_guard<std::mutex> l(g_cache_lock);
    auto it = cache().find(sample);
    if (it != cache().end() && it->second.model == m && it->second.x == key) {
      std::shared_ptr<const Evaluation> e = it->second.e;
      if (last) cache().erase(it);
      return e;
    }
  }
  auto e = std::make_shared<const Evaluation>(m->evaluate(x));
  if (!last && e->ok) {
    std::lock_guard<std::mutex> l(g_cache_lock);
    // Entries of samples the builder dropped before the last callback: bounded.
    if (cache().size() > 64) cache().clear();
    cache()[sample] = Cached{m, key, e};
  }
  return e;
}

cadinterp_status fail(cadinterp_sample* out, const std::string& message) {
  cadinterp_sample_set_message(out, message.c_str());
  return CADINTERP_E_INFEASIBLE;
}

cadinterp_status host_regenerate(void* user, const double* x, cadinterp_sample* out) {
  try {
    const auto ep = evaluation(static_cast<const Model*>(user), x, out, false);
    const Evaluation& e = *ep;
    if (!e.ok) return fail(out, e.message);
    return cadinterp_sample_set_mesh(out, e.vertices.data(), e.vertices.size() / 3, e.tets.data(),
                                     e.tets.size() / 4, e.triangles.data(), e.triangle_tags.data(),
                                     e.triangle_tags.size());
  } catch (const std::bad_alloc&) {
    return CADINTERP_E_OUT_OF_MEMORY;
  } catch (const std::exception& ex) {
    return fail(out, ex.what());
  }
}

cadinterp_status host_references(void* user, const double* x, cadinterp_sample* out) {
  try {
    const auto ep = evaluation(static_cast<const Model*>(user), x, out, true);
    const Evaluation& e = *ep;
    if (!e.ok) return fail(out, e.message);
    for (const ControlPoint& p : e.points) {
      const cadinterp_status s =
          cadinterp_sample_add_point(out, p.id.data(), p.id.size(), p.position);
      if (s != CADINTERP_OK) return s;
    }
    for (const Path& p : e.paths) {
      const cadinterp_status s =
          cadinterp_sample_add_path(out, p.a.data(), p.a.size(), p.b.data(), p.b.size(),
                                    p.polyline.data(), p.polyline.size() / 3);
      if (s != CADINTERP_OK) return s;
    }
    for (const Region& r : e.regions) {
      const cadinterp_status s = cadinterp_sample_add_region(out, r.name.c_str(), r.kind.c_str(),
                                                             r.tags.data(), r.tags.size());
      if (s != CADINTERP_OK) return s;
    }
    // The B-rep's exact volume as a per-sample output: interpolated without the mesh's
    // discretization or mapping error (cadinterp_eval_outputs, `output(brep_volume)`).
    return cadinterp_sample_add_output(out, "brep_volume", e.exact_volume, "mm^3");
  } catch (const std::bad_alloc&) {
    return CADINTERP_E_OUT_OF_MEMORY;
  } catch (const std::exception& ex) {
    return fail(out, ex.what());
  }
}

cadinterp_status host_simulate(void* user, const double* x, const cadinterp_host_mesh* mesh,
                               cadinterp_sample* out) {
  try {
    const Model* m = static_cast<const Model*>(user);
    // The mesh handed in is the one regenerate wrote, or a mapped one in another sample's
    // combinatorics whose face tags name this solid's faces at x (paper §6; the builder's
    // simulate_mapped): either way the FEM takes it as given and needs only the regions at x,
    // which the evaluation at x recorded (no second regeneration).
    const auto named = m->named(x);
    if (!named->ok) return fail(out, named->message);
    Evaluation e;
    e.ok = true;
    e.regions = named->regions;
    e.vertices.assign(mesh->vertices, mesh->vertices + 3 * mesh->vertex_count);
    e.tets.assign(mesh->tets, mesh->tets + 4 * mesh->tet_count);
    e.triangles.assign(mesh->triangles, mesh->triangles + 3 * mesh->triangle_count);
    e.triangle_tags.assign(mesh->triangle_tags, mesh->triangle_tags + mesh->triangle_count);
    const Fields f = m->simulate(x, e);
    const std::size_t nv = mesh->vertex_count;
    if (f.von_mises.size() != nv || f.displacement.size() != 3 * nv)
      return fail(out, "simulate: the FEM returned fields of the wrong size");
    cadinterp_status s = cadinterp_sample_add_field(out, "von_mises", CADINTERP_PER_VERTEX, 1,
                                                    f.von_mises.data(), nv);
    if (s == CADINTERP_OK)
      s = cadinterp_sample_add_field(out, "displacement", CADINTERP_PER_VERTEX, 3,
                                     f.displacement.data(), nv);
    if (s == CADINTERP_OK && m->thermal()) {
      if (f.temperature.size() != nv)
        return fail(out, "simulate: the FEM returned no temperature field");
      s = cadinterp_sample_add_field(out, "temperature", CADINTERP_PER_VERTEX, 1,
                                     f.temperature.data(), nv);
    }
    // The applied load, so that a viewer draws the real load direction (the wrench's load angle
    // turns it; the geometry does not show it).
    if (s == CADINTERP_OK) {
      if (f.traction.size() != 3 * nv)
        return fail(out, "simulate: the FEM returned no traction field");
      s = cadinterp_sample_add_field(out, "traction", CADINTERP_PER_VERTEX, 3, f.traction.data(),
                                     nv);
    }
    // Units of the models (mm, N): stress and traction in MPa = N/mm^2, displacement in mm;
    // temperatures are degrees Celsius (the models' ambient and bore temperatures are 20).
    const char* const units[][2] = {{"von_mises", "MPa"},
                                    {"displacement", "mm"},
                                    {"temperature", "\u00B0C"},
                                    {"traction", "MPa"}};
    for (const auto& u : units)
      if (s == CADINTERP_OK && (u[0] != std::string("temperature") || m->thermal()))
        s = cadinterp_sample_set_field_unit(out, u[0], u[1]);
    // The FEM's largest vertex stress as a per-sample output: a "max stress <= S" constraint on
    // the host's own value, without a smooth maximum over the interpolated field.
    if (s == CADINTERP_OK)
      s = cadinterp_sample_add_output(
          out, "max_von_mises", *std::max_element(f.von_mises.begin(), f.von_mises.end()), "MPa");
    return s;
  } catch (const std::bad_alloc&) {
    return CADINTERP_E_OUT_OF_MEMORY;
  } catch (const std::exception& ex) {
    return fail(out, std::string("simulate: ") + ex.what());
  }
}

// Hosts handed out by the entry, alive until the library is unloaded (cadinterp_builder.h).
std::mutex g_registry_lock;
std::list<std::unique_ptr<Model>>& registry() {
  static std::list<std::unique_ptr<Model>> r;
  return r;
}
// Entry error messages, kept until unload (the entry's contract: library-owned storage).
std::mutex g_error_lock;
std::set<std::string>& errors() {
  static std::set<std::string> e;
  return e;
}

}  // namespace

const Model* host_model(const cadinterp_host* host) {
  if (!host || host->regenerate != host_regenerate) return nullptr;
  std::lock_guard<std::mutex> l(g_registry_lock);
  for (const auto& m : registry())
    if (m.get() == host->user) return m.get();
  return nullptr;
}

}  // namespace cadinterp::occt

extern "C" const cadinterp_host* cadinterp_host_entry(const char* model, const char* options,
                                                      const char** error) {
  using cadinterp::occt::Model;
  std::string message;
  try {
    auto m = std::make_unique<Model>(model ? model : "", options ? options : "");
    std::lock_guard<std::mutex> l(cadinterp::occt::g_registry_lock);
    for (const auto& r : cadinterp::occt::registry())
      if (r->identity() == m->identity()) return r->host();
    cadinterp::occt::registry().push_back(std::move(m));
    return cadinterp::occt::registry().back()->host();
  } catch (const std::exception& ex) {
    message = ex.what();
  } catch (...) {
    message = "occt host: unexpected failure";
  }
  std::lock_guard<std::mutex> l(cadinterp::occt::g_error_lock);
  const auto it = cadinterp::occt::errors().insert(message).first;
  if (error) *error = it->c_str();
  return nullptr;
}
