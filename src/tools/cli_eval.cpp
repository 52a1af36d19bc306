// `cadinterp eval`: the asset evaluated at one parameter vector x through the public C ABI
// (element, error estimate, mesh counts, field ranges, mass properties and, with --grad, their
// derivatives), printed as text or JSON, and the mesh optionally written as .vtu, .obj or glTF.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cli_args.h"
#include "cli_commands.h"
#include "cli_common.h"
#include "json_writer.h"
#include "mesh_export.h"

namespace cadinterp::cli {
namespace {

struct Param {
  std::string name, unit;
  double lower = 0, upper = 0;
};

std::vector<Param> parameters(const cadinterp_asset* a) {
  std::vector<Param> out;
  for (int i = 0; i < cadinterp_parameter_count(a); ++i) {
    cadinterp_parameter_info p{};
    if (cadinterp_parameter(a, i, &p) != CADINTERP_OK) throw RuntimeFailure("parameter query");
    out.push_back({p.name ? p.name : "", p.unit ? p.unit : "", p.lower, p.upper});
  }
  return out;
}

/// Parses the K parameter values; wrong arity and non-numbers are usage errors.
std::vector<double> parse_point(const std::vector<std::string>& tokens,
                                const std::vector<Param>& params) {
  const std::size_t K = params.size();
  std::string names;
  for (const Param& q : params) names += (names.empty() ? "" : ", ") + q.name;
  if (tokens.size() != K)
    throw UsageError(fmt("the asset has %zu parameter%s (%s); got %zu value%s", K,
                         K == 1 ? "" : "s", names.c_str(), tokens.size(),
                         tokens.size() == 1 ? "" : "s"));
  std::vector<double> x(K);
  for (std::size_t i = 0; i < K; ++i)
    if (!parse_double(tokens[i], &x[i]))
      throw UsageError("parameter " + std::to_string(i + 1) + " (" + params[i].name +
                       ") must be a finite number, got '" + tokens[i] + "'");
  return x;
}

/// Outside-domain and infeasible points fail here with the runtime's status and which
/// parameter is out of range, before any mesh work.
int locate_or_fail(const cadinterp_asset* a, const std::vector<double>& x,
                   const std::vector<Param>& params) {
  int element = -1, feasible = 0;
  const cadinterp_status s = cadinterp_locate(a, x.data(), &element, &feasible);
  if (s == CADINTERP_E_OUTSIDE_DOMAIN) {
    std::string why;
    for (std::size_t i = 0; i < params.size(); ++i)
      if (!(x[i] >= params[i].lower && x[i] <= params[i].upper))
        why += fmt("%s%s = %g is outside [%g, %g]", why.empty() ? "" : "; ", params[i].name.c_str(),
                   x[i], params[i].lower, params[i].upper);
    throw RuntimeFailure(describe(s, why));
  }
  if (s != CADINTERP_OK) throw RuntimeFailure("locate: " + describe(s, ""));
  if (!feasible)
    throw RuntimeFailure(describe(
        CADINTERP_E_INFEASIBLE,
        fmt("x lies in element %d, which depends on a sample the host could not build", element)));
  return element;
}

// The properties as named rows, for the tables and JSON alike.
std::vector<std::pair<std::string, double>> property_values(const cadinterp_properties& p) {
  std::vector<std::pair<std::string, double>> v = {
      {"volume", p.volume},
      {"mass", p.mass},
      {"area", p.area},
      {"frontal_area", p.frontal_area},
      {"centroid_x", p.centroid[0]},
      {"centroid_y", p.centroid[1]},
      {"centroid_z", p.centroid[2]},
  };
  const char* axes = "xyz";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      v.push_back({std::string("inertia_") + axes[r] + axes[c], p.inertia[3 * r + c]});
  return v;
}

/// --direction: three numbers, normalised; malformed or zero is a usage error.
void parse_direction(const std::string& spec, double dir[3]) {
  const std::vector<std::string> d = split_list(spec);
  if (d.size() != 3 || !parse_double(d[0], &dir[0]) || !parse_double(d[1], &dir[1]) ||
      !parse_double(d[2], &dir[2]))
    throw UsageError("--direction expects three numbers X,Y,Z, got '" + spec + "'");
  const double n = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  if (!(n > 0)) throw UsageError("--direction must not be the zero vector");
  for (int i = 0; i < 3; ++i) dir[i] /= n;
}

struct EvalArgs {
  std::string path, fields_spec = "all", direction_spec = "1,0,0", vtu, obj, gltf;
  std::vector<std::string> xs;
  bool grad = false, json = false, vtu_ascii = false;
  double density = 1.0;
  double dir[3] = {0, 0, 0};  // direction_spec, normalised
};

struct FieldSummary {
  std::string name;
  bool per_tet;
  int components;
  double min, max;
};
struct Written {
  std::string format, path;
  ExportSummary summary;
};

/// What one evaluation gives: everything the text and JSON printers show.
struct EvalResult {
  std::vector<Param> params;
  std::vector<double> x;
  int element = -1;
  double error_estimate = -1;
  /// cadinterp_error_estimates' field entries, with the fields' names (every field of the asset).
  std::vector<std::pair<std::string, double>> field_error_estimates;
  std::uint32_t V = 0, T = 0, F = 0;
  std::vector<FieldSummary> fields;
  std::vector<Written> written;
  cadinterp_properties props{};
  std::vector<cadinterp_properties> dprops;  // per parameter, with --grad
  // Largest vertex speed |dP_v/dx_d| per parameter: how strongly each parameter moves the shape.
  std::vector<double> max_speed;
};

/// Field ranges and the exports; `mesh` is the workspace's, valid until its next call.
void read_mesh(const cadinterp_asset* asset, const cadinterp_mesh& mesh,
               const std::vector<int>& field_idx, const EvalArgs& a, EvalResult& r) {
  ExportMesh em = export_mesh_of(asset, mesh, field_idx.data(), static_cast<int>(field_idx.size()));
  em.generator = std::string("cadinterp ") + cadinterp_version();
  for (std::size_t i = 0; i < field_idx.size(); ++i) {
    const ExportMesh::Field& f = em.fields[i];
    const std::size_t n = static_cast<std::size_t>(f.per_tet ? mesh.tet_count : mesh.vertex_count) *
                          static_cast<std::size_t>(f.components);
    FieldSummary fs{f.name, f.per_tet, f.components, 0, 0};
    if (n > 0) {
      const auto mm = std::minmax_element(mesh.fields[i], mesh.fields[i] + n);
      fs.min = *mm.first;
      fs.max = *mm.second;
    }
    r.fields.push_back(fs);
  }
  auto do_export = [&](const std::string& fmt_name, const std::string& out, auto writer) {
    if (out.empty()) return;
    try {
      r.written.push_back({fmt_name, out, writer(out)});
    } catch (const std::exception& e) {
      throw RuntimeFailure(
          describe(CADINTERP_E_IO, fmt_name + " export to " + out + ": " + e.what()));
    }
  };
  do_export("vtu", a.vtu, [&](const std::string& f) {
    return write_vtu(f, em, a.vtu_ascii ? VtuEncoding::Ascii : VtuEncoding::Base64);
  });
  do_export("obj", a.obj, [&](const std::string& f) { return write_obj(f, em); });
  do_export("gltf", a.gltf, [&](const std::string& f) { return write_gltf(f, em); });
  r.V = mesh.vertex_count;
  r.T = mesh.tet_count;
  r.F = mesh.triangle_count;
}

EvalResult evaluate(const EvalArgs& a) {
  EvalResult r;
  AssetPtr asset = open_asset(a.path);
  r.params = parameters(asset.get());
  r.x = parse_point(a.xs, r.params);
  const std::vector<int> field_idx = select_fields(asset.get(), a.fields_spec);
  r.element = locate_or_fail(asset.get(), r.x, r.params);
  cadinterp_error_estimate(asset.get(), r.x.data(), &r.error_estimate);
  int count = 0;
  cadinterp_error_estimates(asset.get(), r.x.data(), nullptr, 0, &count);
  std::vector<double> est(static_cast<std::size_t>(count), -1.0);
  cadinterp_error_estimates(asset.get(), r.x.data(), est.data(), count, &count);
  for (int f = 1; f < count; ++f) {
    cadinterp_field_info info{};
    cadinterp_field(asset.get(), f - 1, &info);
    r.field_error_estimates.emplace_back(info.name ? info.name : "",
                                         est[static_cast<std::size_t>(f)]);
  }

  WorkspacePtr ws = make_workspace(asset.get());
  cadinterp_mesh mesh{};
  check_ws(cadinterp_eval(ws.get(), r.x.data(), field_idx.data(),
                          static_cast<int>(field_idx.size()), &mesh),
           ws.get(), "eval");
  // Everything that reads the mesh happens before the next call with this workspace.
  read_mesh(asset.get(), mesh, field_idx, a, r);

  const std::size_t K = r.params.size();
  r.dprops.resize(a.grad ? K : 0);
  check_ws(cadinterp_eval_properties(ws.get(), r.x.data(), a.density, a.dir, &r.props,
                                     a.grad ? r.dprops.data() : nullptr),
           ws.get(), "properties");
  r.max_speed.assign(K, 0.0);
  if (a.grad) {
    cadinterp_mesh_grad g{};
    check_ws(cadinterp_grad(ws.get(), r.x.data(), nullptr, 0, &g), ws.get(), "grad");
    for (std::size_t d = 0; d < K; ++d)
      for (std::size_t v = 0; v < g.vertex_count; ++v) {
        const float* dp = g.dpositions + d * 3 * g.vertex_count + 3 * v;
        r.max_speed[d] = std::max(r.max_speed[d], std::sqrt(static_cast<double>(dp[0]) * dp[0] +
                                                            static_cast<double>(dp[1]) * dp[1] +
                                                            static_cast<double>(dp[2]) * dp[2]));
      }
  }
  return r;
}

void print_json(const EvalArgs& a, const EvalResult& r) {
  const std::vector<Param>& params = r.params;
  std::string out;
  JsonWriter w(out);
  w.begin_object().field("asset", a.path);
  w.key("x").begin_object();
  for (std::size_t i = 0; i < params.size(); ++i) w.field(params[i].name, r.x[i]);
  w.end_object();
  w.field("element", r.element);
  if (r.error_estimate >= 0) {
    w.field("error_estimate", r.error_estimate);
  } else {
    w.key("error_estimate").null();
  }
  w.key("field_error_estimates").begin_object();
  for (const auto& [name, e] : r.field_error_estimates) {
    if (e >= 0)
      w.field(name, e);
    else
      w.key(name).null();
  }
  w.end_object();
  w.field("vertices", r.V).field("tets", r.T).field("triangles", r.F);
  w.key("fields").begin_array();
  for (const FieldSummary& f : r.fields) {
    w.begin_object().field("name", f.name).field("location", f.per_tet ? "tet" : "vertex");
    w.field("components", f.components).field("min", f.min).field("max", f.max).end_object();
  }
  w.end_array();
  w.key("properties").begin_object().field("density", a.density);
  w.key("direction").begin_array().value(a.dir[0]).value(a.dir[1]).value(a.dir[2]).end_array();
  for (const auto& [name, v] : property_values(r.props)) w.field(name, v);
  w.end_object();
  if (a.grad) {
    w.key("gradient").begin_object();
    for (std::size_t d = 0; d < params.size(); ++d) {
      w.key(params[d].name).begin_object();
      for (const auto& [name, v] : property_values(r.dprops[d])) w.field(name, v);
      w.field("max_vertex_speed", r.max_speed[d]).end_object();
    }
    w.end_object();
  }
  w.key("exports").begin_array();
  for (const Written& e : r.written) {
    w.begin_object().field("format", e.format).field("path", e.path);
    w.field("vertices", e.summary.vertices).field("cells", e.summary.cells);
    w.field("bytes", e.summary.bytes).end_object();
  }
  w.end_array().end_object();
  std::fputs(out.c_str(), stdout);
}

void print_text(const EvalArgs& a, const EvalResult& r) {
  const std::vector<Param>& params = r.params;
  const cadinterp_properties& props = r.props;
  std::printf("asset        %s\n", a.path.c_str());
  std::printf("x           ");
  for (std::size_t i = 0; i < params.size(); ++i)
    std::printf("%s %s = %.9g%s%s", i ? "," : "", params[i].name.c_str(), r.x[i],
                params[i].unit.empty() ? "" : " ", params[i].unit.c_str());
  std::printf("\nelement      %d\n", r.element);
  if (r.error_estimate >= 0)
    std::printf("error est.   %.3g (relative to the bounding-box diagonal)\n", r.error_estimate);
  else
    std::printf("error est.   not measured\n");
  for (const auto& [name, e] : r.field_error_estimates)
    if (e >= 0) std::printf("error est.   %-16s %.3g (relative to its range)\n", name.c_str(), e);
  std::printf("mesh         %u vertices, %u tets, %u boundary triangles\n", r.V, r.T, r.F);
  for (const FieldSummary& f : r.fields)
    std::printf("field        %-16s per %-6s %d comp.  min %.6g  max %.6g\n", f.name.c_str(),
                f.per_tet ? "tet" : "vertex", f.components, f.min, f.max);
  std::printf("\nproperties   (density %g, frontal direction %.3g %.3g %.3g)\n", a.density,
              a.dir[0], a.dir[1], a.dir[2]);
  std::printf("  volume        %.9g\n", props.volume);
  std::printf("  mass          %.9g\n", props.mass);
  std::printf("  area          %.9g\n", props.area);
  std::printf("  frontal area  %.9g\n", props.frontal_area);
  std::printf("  centroid      %.9g %.9g %.9g\n", props.centroid[0], props.centroid[1],
              props.centroid[2]);
  for (int i = 0; i < 3; ++i)
    std::printf("  %s  %14.6g %14.6g %14.6g\n", i == 0 ? "inertia     " : "            ",
                props.inertia[3 * i], props.inertia[3 * i + 1], props.inertia[3 * i + 2]);
  if (a.grad) {
    const auto values = property_values(props);
    std::printf("\nderivatives   ");
    for (const Param& q : params) std::printf(" %14s", ("d/d " + q.name).c_str());
    std::printf("\n");
    for (std::size_t i = 0; i < values.size(); ++i) {
      std::printf("  %-12s", values[i].first.c_str());
      for (std::size_t d = 0; d < params.size(); ++d)
        std::printf(" %14.6g", property_values(r.dprops[d])[i].second);
      std::printf("\n");
    }
    std::printf("  %-12s", "max |dP/dx|");
    for (const double s : r.max_speed) std::printf(" %14.6g", s);
    std::printf("\n");
  }
  for (const Written& e : r.written)
    std::printf("wrote        %s (%s: %llu vertices, %llu %s, %s)\n", e.path.c_str(),
                e.format.c_str(), static_cast<unsigned long long>(e.summary.vertices),
                static_cast<unsigned long long>(e.summary.cells),
                e.format == "vtu" ? "tets" : "triangles", human_bytes(e.summary.bytes).c_str());
}

}  // namespace

int cmd_eval(const std::vector<std::string>& args) {
  EvalArgs a;
  ArgParser p(
      "cadinterp eval", "ASSET X1 X2 ... [options]",
      "Evaluates the asset at the parameter vector x (one value per parameter, in the order\n"
      "'cadinterp inspect' lists them): element, error estimate, mesh counts, field ranges and\n"
      "mass properties; with --grad their derivatives. Optionally writes the mesh.");
  p.positional("ASSET", "the asset file (.cadi)", &a.path);
  p.rest("X1 X2 ...", "parameter values (negative values are fine: -0.5)", &a.xs, 0);
  p.option("fields", 0, "A,B", "fields to evaluate and export ('all', or '' for none)",
           &a.fields_spec);
  p.flag("grad", 0, "also print derivatives of the properties with respect to x", &a.grad);
  p.option("density", 0, "RHO", "uniform density for mass and inertia", &a.density, 0, 1e300);
  p.option("direction", 0, "X,Y,Z", "direction of the frontal (projected) area", &a.direction_spec);
  p.option("vtu", 0, "FILE", "write the tet mesh and fields as VTK XML (.vtu)", &a.vtu);
  p.flag("ascii", 0, "write the .vtu as ASCII instead of base64 binary", &a.vtu_ascii);
  p.option("obj", 0, "FILE", "write the boundary triangles as Wavefront OBJ", &a.obj);
  p.option("gltf", 0, "FILE", "write the boundary triangles as glTF 2.0 (.gltf or .glb)", &a.gltf);
  p.flag("json", 0, "print JSON instead of text", &a.json);
  p.epilog(
      "examples:\n"
      "  cadinterp eval part.cadi 0.5 12 --grad\n"
      "  cadinterp eval part.cadi 0.5 12 --fields temperature --vtu x.vtu --gltf x.glb");
  if (!p.parse(args)) return kExitOk;
  if (p.seen("ascii") && a.vtu.empty()) throw UsageError("--ascii applies to --vtu only");
  parse_direction(a.direction_spec, a.dir);

  const EvalResult r = evaluate(a);
  if (a.json)
    print_json(a, r);
  else
    print_text(a, r);
  return kExitOk;
}

}  // namespace cadinterp::cli
