// `cadinterp optimize --verify`: the optimum re-simulated by the host (optimize_verify.h).
#include "optimize_verify.h"

#include <memory>
#include <stdexcept>

#include "core/basis.h"
#include "core/compiled_basis.h"
#include "format/asset_writer.h"
#include "mesh/host_call.h"

namespace cadinterp::cli {

std::string parameter_mismatch(const cadinterp_host& host, const cadinterp_asset* asset) {
  const std::vector<std::string> names = parameter_names(asset);
  auto list = [](const std::vector<std::string>& v) {
    std::string s;
    for (const std::string& n : v) s += (s.empty() ? "" : ", ") + n;
    return s;
  };
  std::vector<std::string> host_names;
  for (int i = 0; i < host.parameter_count; ++i)
    host_names.push_back(host.parameters[i].name ? host.parameters[i].name : "");
  if (host_names == names) return "";
  return "the host has " + std::to_string(host_names.size()) + " parameters (" + list(host_names) +
         "), the asset " + std::to_string(names.size()) + " (" + list(names) + ")";
}

std::vector<std::uint8_t> sample_asset_bytes(const mesh::Sample& s) {
  if (!s.feasible) throw std::runtime_error("the sample is infeasible: " + s.message);
  // The level-0 linear basis on [0, 1]: one element, two terms.
  const core::Basis basis(1, core::Degree::Linear);
  const core::CompiledBasis compiled = core::CompiledBasis::compile(basis, {0.0}, {1.0});
  format::AssetContent c;
  c.basis = &compiled;
  c.parameters.push_back({"constant", "", 0.0, 1.0});
  for (const mesh::Field& f : s.fields)
    c.fields.emplace_back(f.name, static_cast<format::FieldLocation>(f.location), f.components,
                          f.unit);
  for (const mesh::Region& r : s.regions) c.regions.push_back({r.name, r.kind, r.face_tags});
  // The host's own scalar outputs, equal at both samples of the one element, so that an
  // expression naming output(NAME) reads the host's exact value at x*.
  for (const mesh::Output& o : s.outputs) c.outputs.push_back({o.name, o.unit, {o.value, o.value}});
  c.builder_version = "host sample";
  c.host = "host sample";
  c.options_json = "{}";
  format::ElementData e;
  e.vertex_count = static_cast<std::uint32_t>(s.vertex_count());
  e.tets = s.tets;
  e.triangles = s.triangles;
  e.triangle_tags = s.triangle_tags;
  e.canonical.assign(s.vertices.begin(), s.vertices.end());
  std::vector<float> fields;
  for (const mesh::Field& f : s.fields)
    fields.insert(fields.end(), f.values.begin(), f.values.end());
  e.positions.assign(2, e.canonical);
  e.fields.assign(2, fields);
  e.error_estimate = 0.0;
  c.elements.push_back(std::move(e));
  return format::write_asset(c, format::WriteOptions{});  // lossless
}

std::vector<TrueValue> values_on_sample(const mesh::Sample& s, const OptimizeSpec& spec) {
  const std::vector<std::uint8_t> bytes = sample_asset_bytes(s);
  cadinterp_asset* raw = nullptr;
  const cadinterp_status st = cadinterp_open_memory(bytes.data(), bytes.size(), 0, &raw);
  if (st != CADINTERP_OK)
    throw std::runtime_error(std::string("the host's sample does not make an asset: ") +
                             cadinterp_open_error());
  const std::unique_ptr<cadinterp_asset, void (*)(cadinterp_asset*)> asset(raw, cadinterp_close);
  // One problem per function, so that a quantity the sample lacks costs only its own function.
  std::vector<TrueValue> out;
  const double x = 0.5;
  for (std::size_t f = 0; f <= spec.subject_to.size(); ++f) {
    TrueValue v;
    cadinterp_optimize_problem* p = nullptr;
    if (cadinterp_optimize_create(asset.get(), &p) != CADINTERP_OK) throw std::bad_alloc();
    const ProblemPtr problem(p);
    const cadinterp_status ps =
        f == 0 ? cadinterp_optimize_parse(p, 0, spec.minimize.c_str())
               : cadinterp_optimize_parse_constraint(p, spec.subject_to[f - 1].c_str(), nullptr);
    double values[2] = {0.0, 0.0};
    if (ps != CADINTERP_OK) {
      v.reason = std::string("not in the host's sample: ") + cadinterp_optimize_error(p);
    } else if (cadinterp_optimize_evaluate(p, &x, values, nullptr) != CADINTERP_OK) {
      v.reason =
          std::string("cannot be evaluated on the host's sample: ") + cadinterp_optimize_error(p);
    } else {
      v.defined = true;
      v.value = values[f == 0 ? 0 : 1];
    }
    out.push_back(v);
  }
  return out;
}

Verification verify_with_host(const cadinterp_host& host, const double* x,
                              const OptimizeSpec& spec) {
  const mesh::Host h(host);  // throws std::invalid_argument for an inconsistent host
  for (int d = 0; d < h.dim(); ++d) {
    const auto ud = static_cast<std::size_t>(d);
    if (!(x[d] >= h.lower()[ud] && x[d] <= h.upper()[ud]))
      throw std::invalid_argument("x*'s " + h.names()[ud] + " = " + std::to_string(x[d]) +
                                  " lies outside the host's range [" +
                                  std::to_string(h.lower()[ud]) + ", " +
                                  std::to_string(h.upper()[ud]) + "]");
  }
  const mesh::Sample s = h.evaluate(x);
  Verification v;
  v.feasible = s.feasible;
  v.host_seconds = s.host_seconds;
  if (!s.feasible) {
    v.message = s.message;
    for (std::size_t f = 0; f <= spec.subject_to.size(); ++f)
      v.values.push_back({false, 0.0, "the host failed at x*: " + s.message});
    return v;
  }
  v.vertices = s.vertex_count();
  v.tets = s.tet_count();
  v.values = values_on_sample(s, spec);
  return v;
}

GridFunction host_grid_function(const cadinterp_host& host, const OptimizeSpec& spec) {
  return [&host, &spec](const double* x) {
    GridValue g;
    const Verification v = verify_with_host(host, x, spec);
    if (!v.feasible) {
      g.reason = "the host failed: " + v.message;
      return g;
    }
    for (const TrueValue& t : v.values) {
      if (!t.defined) {
        g.reason = t.reason;
        return g;
      }
      g.values.push_back(t.value);
    }
    g.evaluated = true;
    return g;
  };
}

}  // namespace cadinterp::cli
