// libFuzzer target: every query and evaluation entry point of the C ABI (cadinterp.h) on an
// asset opened from fuzzed bytes, at fuzzed parameter vectors, with fuzzed field subsets, cache
// budgets, densities and directions. fuzz_open_eval asks "does a mutated asset crash open or a
// midpoint eval?"; this target asks "does every call keep its documented contract?", so it
// checks the results of successful calls and the outputs of failed ones, and abort()s on any
// broken invariant: a crash is what libFuzzer reports.
//
// Input: a .cadi asset, optionally followed by a control trailer. The asset is the first
// file_size bytes (header offset 16) when the input is longer than that; the rest drives the
// calls (see parse_points_and_rest). Without a trailer a fixed script runs (corners, midpoint,
// dyadic face coordinates, NaN, outside the box, all fields, a one-byte cache budget), so the
// conformance assets are seeds as they are. Checksums are recomputed before opening
// (fuzz_checksums.h), so mutations reach the index checks and the decoders.
//
// Build and run: scripts/fuzz.sh [SECONDS] (seeds: conformance/cases/*/*/asset.cadi and
// src/runtime/fuzz_regressions/fuzz_api-*).
//
// Why one file of over 800 lines: it holds one contract check per entry point of cadinterp.h,
// side by side in the header's order, so that a declaration added there gets its check next to
// its neighbours'; splitting by entry point would scatter the shared script and trailer parsing.
// What is shared with fuzz_open_eval (the checksum fix-up) lives in fuzz_checksums.h.
#include <fuzzer/FuzzedDataProvider.h>
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "cadinterp_generated.h"
#include "fuzz_checksums.h"

namespace {

[[noreturn]] void fail(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
void fail(const char* fmt, ...) {
  std::fprintf(stderr, "fuzz_api invariant violated: ");
  va_list ap;
  va_start(ap, fmt);
  std::vfprintf(stderr, fmt, ap);
  va_end(ap);
  std::fprintf(stderr, "\n");
  std::abort();
}

#define CHECK(cond, ...)            \
  do {                              \
    if (!(cond)) fail(__VA_ARGS__); \
  } while (0)

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Finite outputs are part of the contract, but the reader bounds decoded samples only to be
// finite: samples near FLT_MAX (or a corrupt basis) overflow the blend and its derivatives,
// which the fuzzer finds within seconds. CADINTERP_FUZZ_API_ALLOW_NONFINITE=1 turns these value
// checks off (arrays are still read to their end) so that a run can get past that class of
// finding to the rest; the default is strict.
bool g_check_values = true;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- The script ----------------------------------------------------------------------------

enum class OpenMode { InPlace, CopyThenFree, Misaligned };

struct Script {
  OpenMode open_mode = OpenMode::InPlace;
  int misalign = 0;
  // Applied before each point; SIZE_MAX leaves the default. Tiny budgets make every element
  // switch evict the previous element while a workspace still references it.
  std::vector<std::size_t> budgets;
  std::vector<std::vector<double>> points;
  std::vector<int> fields;
  int field_count = 0;  // may disagree with fields.size() to test the argument checks
  double density = 1.0;
  double direction[3] = {0, 0, 1};
  bool property_grads = true;
  int adjoint_kind = 0;
};

struct Box {
  std::vector<double> lo, hi;
};

double coordinate(FuzzedDataProvider& in, double lo, double hi) {
  switch (in.ConsumeIntegralInRange(0, 13)) {
    case 0:
      return lo + in.ConsumeProbability<double>() * (hi - lo);
    case 1:
      return lo;
    case 2:
      return hi;
    case 3:
      return lo + 0.5 * (hi - lo);
    case 4:
      return kNaN;
    case 5:
      return kInf;
    case 6:
      return -kInf;
    case 7:
      return std::nextafter(lo, -kInf);
    case 8:
      return std::nextafter(hi, kInf);
    case 9:
      return std::nextafter(lo, kInf);
    case 10:
      return std::nextafter(hi, -kInf);
    case 11: {
      const auto bits = in.ConsumeIntegral<std::uint64_t>();
      double v;
      std::memcpy(&v, &bits, sizeof v);
      return v;
    }
    case 12: {
      // Tree faces and samples sit at dyadic fractions of the box: T-junctions, face ties.
      const int level = in.ConsumeIntegralInRange(1, 8);
      const int k = in.ConsumeIntegralInRange(0, 1 << level);
      return lo + std::ldexp(k, -level) * (hi - lo);
    }
    default:
      return -0.0;
  }
}

Script default_script(const Box& box, int field_count) {
  Script s;
  const std::size_t K = box.lo.size();
  auto at = [&](double u) {
    std::vector<double> x(K);
    for (std::size_t d = 0; d < K; ++d) x[d] = box.lo[d] + u * (box.hi[d] - box.lo[d]);
    return x;
  };
  for (double u : {0.5, 0.0, 1.0, 0.37, 0.25, 0.75}) s.points.push_back(at(u));
  s.points.push_back(at(0.5));
  s.points.back()[0] = kNaN;
  s.points.push_back(at(1.5));
  s.budgets = {SIZE_MAX, 1, 1, 0, 1, 1, SIZE_MAX, 1};
  for (int f = 0; f < field_count; ++f) s.fields.push_back(f);
  s.field_count = field_count;
  return s;
}

void parse_points_and_rest(FuzzedDataProvider& in, const Box& box, int fields, Script& s) {
  const std::size_t K = box.lo.size();
  const int n = in.ConsumeIntegralInRange(1, 6);
  for (int p = 0; p < n; ++p) {
    std::vector<double> x(K);
    for (std::size_t d = 0; d < K; ++d) x[d] = coordinate(in, box.lo[d], box.hi[d]);
    s.points.push_back(std::move(x));
    constexpr std::size_t kBudgets[] = {SIZE_MAX, 0, 1, 4096, std::size_t(1) << 20};
    s.budgets.push_back(kBudgets[in.ConsumeIntegralInRange(0, 4)]);
  }
  // Field subsets: in range, repeated, out of range (-1, count), and a count that disagrees.
  const int nf = in.ConsumeIntegralInRange(0, 4);
  for (int i = 0; i < nf; ++i) s.fields.push_back(in.ConsumeIntegralInRange(-1, fields));
  s.field_count = in.ConsumeIntegralInRange(0, 7) == 0 ? -1 : nf;
  const double densities[] = {1.0, 0.0, -2.5, 7850.0, 1e-3, kNaN, kInf, 1e300};
  s.density = densities[in.ConsumeIntegralInRange(0, 7)];
  switch (in.ConsumeIntegralInRange(0, 5)) {
    case 0:
      break;
    case 1:
      s.direction[0] = 1, s.direction[2] = 0;
      break;
    case 2: {
      double n2 = 0;
      for (double& c : s.direction) {
        c = in.ConsumeFloatingPointInRange(-1.0, 1.0);
        n2 += c * c;
      }
      if (n2 > 0)
        for (double& c : s.direction) c /= std::sqrt(n2);
      break;
    }
    case 3:
      s.direction[2] = 0;
      break;
    case 4:
      s.direction[1] = kNaN;
      break;
    default:
      s.direction[0] = 1e300;
  }
  s.property_grads = in.ConsumeBool();
  s.adjoint_kind = in.ConsumeIntegralInRange(0, 3);
}

// ---- Invariants ----------------------------------------------------------------------------

template <typename T>
void poison(T* p) {
  std::memset(static_cast<void*>(p), 0xA5, sizeof(T));
}
template <typename T>
bool poisoned(const T* p) {
  const auto* b = reinterpret_cast<const unsigned char*>(p);
  for (std::size_t i = 0; i < sizeof(T); ++i)
    if (b[i] != 0xA5) return false;
  return true;
}

// Every array is read to its documented end, so ASan reports one that is shorter.
void check_finite(const float* a, std::size_t n, const char* what) {
  CHECK(n == 0 || a != nullptr, "%s: NULL for %zu values", what, n);
  std::size_t bad = n;
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(a[i]) && bad == n) bad = i;
  CHECK(bad == n || !g_check_values, "%s[%zu] = %g is not finite", what, bad,
        static_cast<double>(a[bad]));
}

void check_indices(const std::uint32_t* a, std::size_t n, std::uint32_t vertex_count,
                   const char* what) {
  CHECK(n == 0 || a != nullptr, "%s: NULL for %zu values", what, n);
  for (std::size_t i = 0; i < n; ++i)
    CHECK(a[i] < vertex_count, "%s[%zu] = %u >= vertex count %u", what, i, a[i], vertex_count);
}

const char* name(cadinterp_status s) { return cadinterp_status_string(s); }

struct MeshCopy {
  bool valid = false;
  cadinterp_mesh mesh{};
  std::vector<float> positions;
  std::vector<std::uint32_t> tets, triangles;
  std::vector<std::vector<float>> fields;
};

// What the calls at one point share: the point, the element locate found, the base status (eval
// without fields) that every other call must agree with, and the field status the first call
// that reads fields decided.
struct PointCalls {
  PointCalls(const Script& script, cadinterp_workspace* w, const double* at)
      : s(script), ws(w), x(at) {}

  const Script& s;
  cadinterp_workspace* ws;
  const double* x;
  bool inside = true;
  int element = -7, feasible = -7;
  cadinterp_status base = CADINTERP_OK;
  bool base_overflowed = false;
  std::uint32_t V = 0;
  std::vector<float> base_positions;
  bool args_ok = false;
  int nf = 0;                      // fields asked, when the arguments are valid
  std::vector<std::size_t> sizes;  // values per asked field, when the base eval succeeded
  const int* fields = nullptr;
  int count = 0;
  // Field arrays are decoded by the first call that reads them, apart from the shape, and a
  // failed decode keeps nothing: so every call that reads fields must report the same status
  // (OK or the decode error), and every call that does not must report the base status.
  bool field_status_known = false;
  cadinterp_status field_status = CADINTERP_OK;

  // A result that overflows single precision is refused per call (grad can overflow where eval
  // does not), so it is exempt from agreement; it must name itself.
  bool overflowed(cadinterp_status st) const {
    return st == CADINTERP_E_CORRUPT_BLOB &&
           std::strstr(cadinterp_workspace_error(ws), "not finite") != nullptr;
  }
  void check_status(cadinterp_status got, bool reads_fields, const char* call) {
    if (args_ok && (overflowed(got) || (base_overflowed && got == CADINTERP_OK))) return;
    if (!args_ok) {
      CHECK(got == CADINTERP_E_INVALID_ARGUMENT, "%s with invalid fields: %s", call, name(got));
    } else if (base != CADINTERP_OK || !reads_fields) {
      CHECK(got == base, "%s: %s, eval without fields %s", call, name(got), name(base));
    } else if (!field_status_known) {
      CHECK(got == CADINTERP_OK || got == CADINTERP_E_CHECKSUM || got == CADINTERP_E_CORRUPT_BLOB,
            "%s reading fields: %s (%s)", call, name(got), cadinterp_workspace_error(ws));
      field_status_known = true;
      field_status = got;
    } else {
      CHECK(got == field_status, "%s reading fields: %s, an earlier call %s", call, name(got),
            name(field_status));
    }
  }
};

class Run {
 public:
  Run(cadinterp_asset* a, const cadinterp::fb::Asset* index) : a_(a), index_(index) {}

  void queries();
  Box box() const { return box_; }
  void points(const Script& s);

 private:
  // Values per field per element: #V or #T times components.
  std::size_t field_values(int f, const cadinterp_mesh& m) const {
    const auto& info = fields_[static_cast<std::size_t>(f)];
    return (info.location == CADINTERP_PER_VERTEX ? m.vertex_count : m.tet_count) *
           static_cast<std::size_t>(info.components);
  }
  bool fields_valid(const Script& s) const {
    if (s.field_count < 0) return false;
    for (int i = 0; i < s.field_count; ++i)
      if (s.fields[static_cast<std::size_t>(i)] < 0 ||
          s.fields[static_cast<std::size_t>(i)] >= static_cast<int>(fields_.size()))
        return false;
    return true;
  }
  void point(const Script& s, std::size_t p, cadinterp_workspace* ws, MeshCopy& keep);
  void locate(PointCalls& c);
  void base_eval(PointCalls& c);
  void eval_subset(const PointCalls& c);
  void grad(PointCalls& c);
  void vjp(PointCalls& c);
  void properties(const PointCalls& c);
  void eval_fields(PointCalls& c, MeshCopy& keep);
  void check_mesh(const cadinterp_mesh& m, int element, const Script& s, int nf);
  void check_failure(cadinterp_workspace* ws, cadinterp_status st, const char* call);

  cadinterp_asset* a_;
  const cadinterp::fb::Asset* index_;
  int K_ = 0, elements_ = 0;
  Box box_;
  std::vector<cadinterp_field_info> fields_;
};

void Run::queries() {
  int fmt_major = 0, fmt_minor = -1;
  cadinterp_format_version(&fmt_major, &fmt_minor);
  CHECK(cadinterp_version() && fmt_major == 1 && fmt_minor >= 0, "versions");
  K_ = cadinterp_parameter_count(a_);
  CHECK(K_ >= 1 && K_ <= 8, "dim %d", K_);
  const int degree = cadinterp_degree(a_);
  CHECK(degree == 1 || degree == 3, "degree %d", degree);
  elements_ = cadinterp_element_count(a_);
  CHECK(elements_ >= 1 &&
            static_cast<flatbuffers::uoffset_t>(elements_) == index_->elements()->size(),
        "element count %d", elements_);
  int major = -1, minor = -1;
  // Files of minor 2 and later repeat their minor in the index (format_version.cpp, SPEC.md
  // "Versions and features"); before that, a file is 1.1 exactly when some field has a unit.
  bool any_unit = false;
  if (index_->fields())
    for (const auto* f : *index_->fields()) any_unit = any_unit || (f->unit() && f->unit()->size());
  const bool minor_in_index =
      flatbuffers::IsFieldPresent(index_, cadinterp::fb::Asset::VT_FORMAT_MINOR);
  const int expected_minor = minor_in_index ? index_->format_minor() : (any_unit ? 1 : 0);
  CHECK(cadinterp_asset_format(a_, &major, &minor) == CADINTERP_OK && major == 1 &&
            minor == expected_minor && (minor_in_index ? minor >= 2 : minor <= 1),
        "asset format %d.%d (index minor %s, %s field units)", major, minor,
        minor_in_index ? "present" : "absent", any_unit ? "with" : "without");

  for (int i = 0; i < K_; ++i) {
    cadinterp_parameter_info p;
    CHECK(cadinterp_parameter(a_, i, &p) == CADINTERP_OK, "parameter %d", i);
    CHECK(p.name && p.unit, "parameter %d: NULL name or unit", i);
    (void)std::strlen(p.name), (void)std::strlen(p.unit);
    CHECK(std::isfinite(p.lower) && std::isfinite(p.upper) && p.lower < p.upper,
          "parameter %d range [%g, %g]", i, p.lower, p.upper);
    box_.lo.push_back(p.lower);
    box_.hi.push_back(p.upper);
  }
  for (int i : {-1, K_}) {
    cadinterp_parameter_info p;
    poison(&p);
    CHECK(cadinterp_parameter(a_, i, &p) == CADINTERP_E_INVALID_ARGUMENT && poisoned(&p),
          "parameter(%d) accepted or wrote its output", i);
  }

  const int nf = cadinterp_field_count(a_);
  CHECK(nf >= 0, "field count %d", nf);
  for (int i = 0; i < nf; ++i) {
    cadinterp_field_info f;
    CHECK(cadinterp_field(a_, i, &f) == CADINTERP_OK, "field %d", i);
    CHECK(f.name != nullptr, "field %d: NULL name", i);
    CHECK(f.location == CADINTERP_PER_VERTEX || f.location == CADINTERP_PER_TET,
          "field %d location %d", i, static_cast<int>(f.location));
    CHECK(f.components >= 1 && f.components <= 64, "field %d components %d", i, f.components);
    CHECK(f.max_abs_error >= 0 && std::isfinite(f.max_abs_error), "field %d error bound %g", i,
          f.max_abs_error);
    int found = -1;
    CHECK(cadinterp_find_field(a_, f.name, &found) == CADINTERP_OK && found >= 0 && found <= i,
          "find_field(\"%s\") = %d for field %d", f.name, found, i);
    cadinterp_field_info g;
    cadinterp_field(a_, found, &g);
    CHECK(std::strcmp(g.name, f.name) == 0, "find_field found another name");
    const char* unit = nullptr;
    CHECK(cadinterp_field_unit(a_, i, &unit) == CADINTERP_OK && unit != nullptr, "field_unit(%d)",
          i);
    CHECK(std::strlen(unit) < (std::size_t(1) << 31), "field %d unit length", i);
    fields_.push_back(f);
  }
  {
    cadinterp_field_info f;
    poison(&f);
    CHECK(cadinterp_field(a_, nf, &f) == CADINTERP_E_INVALID_ARGUMENT && poisoned(&f),
          "field(count) accepted or wrote its output");
    const char* const untouched = "untouched";
    const char* unit = untouched;
    CHECK(cadinterp_field_unit(a_, nf, &unit) == CADINTERP_E_INVALID_ARGUMENT && unit == untouched,
          "field_unit(count) accepted or wrote its output");
    int idx = 12345;
    CHECK(cadinterp_find_field(a_, nullptr, &idx) == CADINTERP_E_INVALID_ARGUMENT && idx == 12345,
          "find_field(NULL)");
  }

  const int nr = cadinterp_region_count(a_);
  CHECK(nr >= 0, "region count %d", nr);
  for (int i = 0; i < nr; ++i) {
    cadinterp_region_info r;
    CHECK(cadinterp_region(a_, i, &r) == CADINTERP_OK, "region %d", i);
    CHECK(r.name && r.kind && r.face_tag_count >= 0 && (r.face_tag_count == 0 || r.face_tags),
          "region %d: NULL strings or tags", i);
    (void)std::strlen(r.name), (void)std::strlen(r.kind);
    volatile std::uint32_t sink = 0;
    for (int t = 0; t < r.face_tag_count; ++t)
      sink = sink + static_cast<std::uint32_t>(r.face_tags[t]);
  }
  cadinterp_region_info r;
  CHECK(cadinterp_region(a_, nr, &r) == CADINTERP_E_INVALID_ARGUMENT, "region(count)");

  cadinterp_provenance pv;
  CHECK(cadinterp_asset_provenance(a_, &pv) == CADINTERP_OK && pv.builder_version && pv.host &&
            pv.options,
        "provenance");
  (void)std::strlen(pv.builder_version), (void)std::strlen(pv.host), (void)std::strlen(pv.options);

  cadinterp_workspace* ws = nullptr;
  CHECK(cadinterp_workspace_create(nullptr, &ws) == CADINTERP_E_INVALID_ARGUMENT && !ws,
        "workspace_create(NULL)");
  CHECK(cadinterp_locate(a_, nullptr, &major, nullptr) == CADINTERP_E_INVALID_ARGUMENT,
        "locate(x = NULL)");
}

void Run::check_failure(cadinterp_workspace* ws, cadinterp_status st, const char* call) {
  CHECK(st != CADINTERP_E_INTERNAL, "%s: internal error: %s", call, cadinterp_workspace_error(ws));
  const char* msg = cadinterp_workspace_error(ws);
  CHECK(msg && *msg, "%s failed (%s) without a message", call, name(st));
}

void Run::check_mesh(const cadinterp_mesh& m, int element, const Script& s, int nf) {
  CHECK(m.element == element, "eval: element %d, locate said %d", m.element, element);
  const auto* em = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(element));
  CHECK(m.vertex_count == em->vertex_count() && m.tet_count == em->tet_count() &&
            m.triangle_count == em->triangle_count(),
        "eval: counts %u/%u/%u, index %u/%u/%u", m.vertex_count, m.tet_count, m.triangle_count,
        em->vertex_count(), em->tet_count(), em->triangle_count());
  CHECK(m.vertex_count > 0, "eval succeeded on an element without vertices");
  check_indices(m.tets, std::size_t(m.tet_count) * 4, m.vertex_count, "tets");
  check_indices(m.triangles, std::size_t(m.triangle_count) * 3, m.vertex_count, "triangles");
  CHECK(m.triangle_count == 0 || m.triangle_tags, "eval: NULL triangle tags");
  volatile std::uint32_t sink = 0;
  for (std::uint32_t i = 0; i < m.triangle_count; ++i)
    sink = sink + static_cast<std::uint32_t>(m.triangle_tags[i]);
  check_finite(m.positions, std::size_t(m.vertex_count) * 3, "positions");
  CHECK(nf == 0 || m.fields, "eval: NULL fields");
  for (int i = 0; i < nf; ++i)
    check_finite(m.fields[i], field_values(s.fields[static_cast<std::size_t>(i)], m), "field");
}

MeshCopy copy_mesh(const cadinterp_mesh& m, const std::vector<std::size_t>& field_sizes) {
  MeshCopy c;
  c.valid = true;
  c.mesh = m;
  c.positions.assign(m.positions, m.positions + std::size_t(m.vertex_count) * 3);
  c.tets.assign(m.tets, m.tets + std::size_t(m.tet_count) * 4);
  c.triangles.assign(m.triangles, m.triangles + std::size_t(m.triangle_count) * 3);
  for (std::size_t i = 0; i < field_sizes.size(); ++i)
    c.fields.emplace_back(m.fields[i], m.fields[i] + field_sizes[i]);
  return c;
}

// A workspace's last eval stays valid until its next call, whatever other workspaces and cache
// budgets do meanwhile (cadinterp_set_cache_budget: "an element in use by a workspace stays
// alive until released").
void check_still_valid(const MeshCopy& c) {
  if (!c.valid) return;
  const cadinterp_mesh& m = c.mesh;
  CHECK(std::memcmp(c.positions.data(), m.positions, c.positions.size() * 4) == 0 &&
            (c.tets.empty() || std::memcmp(c.tets.data(), m.tets, c.tets.size() * 4) == 0) &&
            (c.triangles.empty() ||
             std::memcmp(c.triangles.data(), m.triangles, c.triangles.size() * 4) == 0),
        "an earlier eval's mesh changed under another workspace's calls");
  for (std::size_t i = 0; i < c.fields.size(); ++i)
    CHECK(c.fields[i].empty() ||
              std::memcmp(c.fields[i].data(), m.fields[i], c.fields[i].size() * 4) == 0,
          "an earlier eval's field changed under another workspace's calls");
}

// locate: status decided by the box alone; error_estimate also by the element's feasibility.
void Run::locate(PointCalls& c) {
  const double* x = c.x;
  cadinterp_status st = cadinterp_locate(a_, x, &c.element, &c.feasible);
  CHECK(st == (c.inside ? CADINTERP_OK : CADINTERP_E_OUTSIDE_DOMAIN), "locate: %s, inside %d",
        name(st), c.inside);
  if (st == CADINTERP_OK) {
    CHECK(c.element >= 0 && c.element < elements_ && (c.feasible == 0 || c.feasible == 1),
          "locate: element %d of %d, feasible %d", c.element, elements_, c.feasible);
    const auto* flags = index_->basis()->elem_feasible();
    CHECK(flags && (flags->Get(static_cast<flatbuffers::uoffset_t>(c.element)) != 0) ==
                       (c.feasible != 0),
          "locate: feasible flag disagrees with the index");
    int again = -7;
    CHECK(cadinterp_locate(a_, x, &again, nullptr) == CADINTERP_OK && again == c.element,
          "locate without feasible");
  } else {
    CHECK(c.element == -7 && c.feasible == -7, "locate wrote its outputs on failure");
  }
  double err = -7.5;
  const cadinterp_status st_err = cadinterp_error_estimate(a_, x, &err);
  const cadinterp_status want = st == CADINTERP_OK && c.feasible == 0 ? CADINTERP_E_INFEASIBLE : st;
  CHECK(st_err == want, "error_estimate: %s, locate %s", name(st_err), name(st));
  if (st_err == CADINTERP_OK) {
    const auto* em = index_->elements()->Get(static_cast<flatbuffers::uoffset_t>(c.element));
    // Without an error model the element's stored value; with one, a finite per-point value.
    CHECK(std::isfinite(err) && (em->error_model() || err == em->error_estimate()),
          "error_estimate %g, index %g", err, em->error_estimate());
  } else {
    CHECK(err == -7.5, "error_estimate wrote its output on failure");
  }
}

// eval without fields: the base status every other evaluation must agree with. Also sizes the
// asked fields from its mesh.
void Run::base_eval(PointCalls& c) {
  cadinterp_mesh m;
  poison(&m);
  c.base = cadinterp_eval(c.ws, c.x, nullptr, 0, &m);
  if (!c.inside) {
    CHECK(c.base == CADINTERP_E_OUTSIDE_DOMAIN, "eval outside the box: %s", name(c.base));
  } else if (!c.feasible) {
    CHECK(c.base == CADINTERP_E_INFEASIBLE, "eval in an infeasible element: %s", name(c.base));
  } else {
    CHECK(c.base == CADINTERP_OK || c.base == CADINTERP_E_CHECKSUM ||
              c.base == CADINTERP_E_CORRUPT_BLOB,
          "eval in a feasible element: %s (%s)", name(c.base), cadinterp_workspace_error(c.ws));
  }
  if (c.base == CADINTERP_OK) {
    check_mesh(m, c.element, c.s, 0);
    c.V = m.vertex_count;
    c.base_positions.assign(m.positions, m.positions + std::size_t(c.V) * 3);
  } else {
    check_failure(c.ws, c.base, "eval");
    CHECK(poisoned(&m), "eval wrote its output on failure");
  }
  c.args_ok = fields_valid(c.s);
  c.nf = c.args_ok ? c.s.field_count : 0;
  c.sizes.assign(static_cast<std::size_t>(c.nf), 0);
  if (c.base == CADINTERP_OK)
    for (int i = 0; i < c.nf; ++i)
      c.sizes[static_cast<std::size_t>(i)] =
          field_values(c.s.fields[static_cast<std::size_t>(i)], m);
  c.fields = c.s.fields.empty() ? nullptr : c.s.fields.data();
  c.count = c.s.field_count;
}

// eval_subset without fields: rows of the asked vertices are the full eval's rows up to float
// rounding (same weights and term order; the full eval's vector kernel may fuse multiply-adds
// where the row kernel does not); an id past #V is refused with the output untouched.
void Run::eval_subset(const PointCalls& c) {
  const std::uint32_t V = c.V;
  float scale = 1.0f;
  for (float p : c.base_positions) scale = std::max(scale, std::fabs(p));
  const std::uint32_t ids[4] = {V - 1, 0, V / 2, V - 1};
  cadinterp_mesh sub;
  poison(&sub);
  cadinterp_status st = cadinterp_eval_subset(c.ws, c.x, ids, 4, nullptr, 0, nullptr, 0, &sub);
  if (st == CADINTERP_OK) {
    CHECK(sub.vertex_count == V, "eval_subset: #V %u, eval %u", sub.vertex_count, V);
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) {
        const float got = sub.positions[3 * i + k];
        const float want = c.base_positions[3 * std::size_t(ids[i]) + std::size_t(k)];
        CHECK(std::fabs(got - want) <= 1e-4f * scale, "eval_subset row %d (vertex %u) %g, eval %g",
              i, ids[i], double(got), double(want));
      }
  } else {
    CHECK(st == CADINTERP_E_CHECKSUM || st == CADINTERP_E_CORRUPT_BLOB,
          "eval_subset after a successful eval: %s", name(st));
    check_failure(c.ws, st, "eval_subset");
    CHECK(poisoned(&sub), "eval_subset wrote its output on failure");
  }
  const std::uint32_t past = V;
  poison(&sub);
  st = cadinterp_eval_subset(c.ws, c.x, &past, 1, nullptr, 0, nullptr, 0, &sub);
  CHECK(st == CADINTERP_E_INVALID_ARGUMENT || st == CADINTERP_E_CHECKSUM ||
            st == CADINTERP_E_CORRUPT_BLOB,
        "eval_subset with vertex #V: %s", name(st));
  CHECK(poisoned(&sub), "eval_subset wrote its output on failure");
}

void Run::grad(PointCalls& c) {
  cadinterp_mesh_grad g;
  poison(&g);
  const cadinterp_status st = cadinterp_grad(c.ws, c.x, c.fields, c.count, &g);
  c.check_status(st, c.nf > 0, "grad");
  if (st == CADINTERP_OK) {
    const std::uint32_t V = c.V;
    CHECK(g.element == c.element && g.vertex_count == V, "grad: element %d / %u vertices",
          g.element, g.vertex_count);
    check_finite(g.positions, std::size_t(V) * 3, "grad positions");
    check_finite(g.dpositions, std::size_t(K_) * V * 3, "dpositions");
    CHECK(c.nf == 0 || g.dfields, "grad: NULL dfields");
    for (int i = 0; i < c.nf; ++i)
      check_finite(g.dfields[i], std::size_t(K_) * c.sizes[static_cast<std::size_t>(i)], "dfields");
  } else {
    check_failure(c.ws, st, "grad");
    CHECK(poisoned(&g), "grad wrote its output on failure");
  }
}

// vjp: adjoints sized exactly, so an over-read is an ASan report.
void Run::vjp(PointCalls& c) {
  const Script& s = c.s;
  const int nf = c.nf;
  std::vector<float> adj_p;
  std::vector<std::vector<float>> adj_f(static_cast<std::size_t>(nf));
  std::vector<const float*> adj_ptrs(static_cast<std::size_t>(nf), nullptr);
  if (c.base == CADINTERP_OK) {
    if (s.adjoint_kind != 1) {
      adj_p.resize(std::size_t(c.V) * 3);
      for (std::size_t i = 0; i < adj_p.size(); ++i)
        adj_p[i] = s.adjoint_kind == 2 ? (i % 2 ? -1.f : 1.f) : 1.f / static_cast<float>(1 + i % 7);
    }
    for (int i = 0; i < nf; ++i) {
      if (s.adjoint_kind == 3 && i % 2) continue;
      adj_f[static_cast<std::size_t>(i)].assign(c.sizes[static_cast<std::size_t>(i)], 0.5f);
      adj_ptrs[static_cast<std::size_t>(i)] = adj_f[static_cast<std::size_t>(i)].data();
    }
  }
  std::vector<double> dfdx(static_cast<std::size_t>(K_), -7.5);
  const bool field_adjoints = s.adjoint_kind != 0 && nf > 0;
  const cadinterp_status st =
      cadinterp_vjp(c.ws, c.x, adj_p.empty() ? nullptr : adj_p.data(), c.fields,
                    field_adjoints ? adj_ptrs.data() : nullptr, c.count, dfdx.data());
  c.check_status(st, field_adjoints, "vjp");
  if (st == CADINTERP_OK) {
    for (int k = 0; k < K_; ++k)
      CHECK(std::isfinite(dfdx[static_cast<std::size_t>(k)]) || !g_check_values,
            "vjp: dF/dx[%d] = %g", k, dfdx[static_cast<std::size_t>(k)]);
  } else {
    check_failure(c.ws, st, "vjp");
    for (double v : dfdx) CHECK(v == -7.5, "vjp wrote its output on failure");
  }
}

// eval_properties, with and without gradients.
void Run::properties(const PointCalls& c) {
  const Script& s = c.s;
  cadinterp_properties props;
  poison(&props);
  std::vector<cadinterp_properties> pgrad(static_cast<std::size_t>(K_));
  for (auto& pg : pgrad) poison(&pg);
  const cadinterp_status st = cadinterp_eval_properties(c.ws, c.x, s.density, s.direction, &props,
                                                        s.property_grads ? pgrad.data() : nullptr);
  // A non-finite density or direction is the caller's invalid argument.
  bool properties_args_ok = std::isfinite(s.density);
  for (double d : s.direction) properties_args_ok = properties_args_ok && std::isfinite(d);
  // Mass properties may overflow where the mesh does not (a huge density, or gradients over a
  // tiny parameter range): that refusal names itself.
  CHECK(st == (properties_args_ok ? c.base : CADINTERP_E_INVALID_ARGUMENT) ||
            (properties_args_ok && c.base == CADINTERP_OK && c.overflowed(st)),
        "eval_properties: %s, eval %s", name(st), name(c.base));
  if (st == CADINTERP_OK) {
    // With a moderate density and direction, volume, mass and areas are sums of products of
    // finite floats in double: finite. Centroid and inertia divide by the volume (NaN when it
    // is 0, documented); they may be NaN but never infinite.
    bool moderate = std::fabs(s.density) <= 1e6;
    for (double d : s.direction) moderate = moderate && std::isfinite(d) && std::fabs(d) <= 10;
    if (moderate && g_check_values) {
      CHECK(std::isfinite(props.volume) && std::isfinite(props.mass) && std::isfinite(props.area) &&
                std::isfinite(props.frontal_area),
            "properties: volume %g mass %g area %g frontal %g", props.volume, props.mass,
            props.area, props.frontal_area);
      CHECK(props.area >= 0 && props.frontal_area >= 0, "properties: negative area");
      for (double v : props.centroid) CHECK(!std::isinf(v), "properties: infinite centroid");
      for (double v : props.inertia) CHECK(!std::isinf(v), "properties: infinite inertia");
      for (int k = 0; s.property_grads && k < K_; ++k) {
        const cadinterp_properties& pg = pgrad[static_cast<std::size_t>(k)];
        CHECK(std::isfinite(pg.volume) && std::isfinite(pg.mass) && std::isfinite(pg.area) &&
                  std::isfinite(pg.frontal_area),
              "properties gradient %d: volume %g mass %g area %g frontal %g", k, pg.volume, pg.mass,
              pg.area, pg.frontal_area);
      }
    }
  } else {
    check_failure(c.ws, st, "eval_properties");
    CHECK(poisoned(&props), "eval_properties wrote its output on failure");
    for (const auto& pg : pgrad) CHECK(poisoned(&pg), "eval_properties wrote its gradient");
  }
}

// eval with the field subset last, so its mesh is what the workspace holds when the other
// workspace runs the next point; `keep` copies it for check_still_valid.
void Run::eval_fields(PointCalls& c, MeshCopy& keep) {
  cadinterp_mesh m;
  poison(&m);
  const cadinterp_status st = cadinterp_eval(c.ws, c.x, c.fields, c.count, &m);
  c.check_status(st, c.nf > 0, "eval with fields");
  keep = MeshCopy();
  if (st == CADINTERP_OK) {
    check_mesh(m, c.element, c.s, c.nf);
    // Same x, same element, decoded again if the cache dropped it: the same bits.
    CHECK(std::memcmp(c.base_positions.data(), m.positions, c.base_positions.size() * 4) == 0,
          "eval is not deterministic across field subsets or cache evictions");
    keep = copy_mesh(m, c.sizes);
  } else {
    check_failure(c.ws, st, "eval with fields");
    CHECK(poisoned(&m), "eval wrote its output on failure");
  }
}

// Every entry point at point p of the script, on workspace ws.
void Run::point(const Script& s, std::size_t p, cadinterp_workspace* ws, MeshCopy& keep) {
  PointCalls c(s, ws, s.points[p].data());
  for (int d = 0; d < K_; ++d)
    c.inside = c.inside && c.x[d] >= box_.lo[static_cast<std::size_t>(d)] &&
               c.x[d] <= box_.hi[static_cast<std::size_t>(d)];
  locate(c);
  base_eval(c);
  if (c.base == CADINTERP_OK && c.V > 0) eval_subset(c);
  c.base_overflowed = c.overflowed(c.base);
  grad(c);
  vjp(c);
  properties(c);
  eval_fields(c, keep);
}

void Run::points(const Script& s) {
  cadinterp_workspace* ws[2] = {nullptr, nullptr};
  for (auto*& w : ws) CHECK(cadinterp_workspace_create(a_, &w) == CADINTERP_OK && w, "workspace");
  MeshCopy keep[2];
  for (std::size_t p = 0; p < s.points.size(); ++p) {
    if (s.budgets[p] != SIZE_MAX)
      CHECK(cadinterp_set_cache_budget(a_, s.budgets[p]) == CADINTERP_OK, "set_cache_budget");
    const std::size_t w = p % 2;
    point(s, p, ws[w], keep[w]);
    check_still_valid(keep[1 - w]);
  }
  for (auto* w : ws) cadinterp_workspace_destroy(w);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* relax = std::getenv("CADINTERP_FUZZ_API_ALLOW_NONFINITE");
  g_check_values = !(relax && std::strcmp(relax, "1") == 0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // The asset is the first file_size bytes when a trailer follows; else the whole input.
  std::size_t asset_size = size;
  if (size >= 48) {
    const std::uint64_t declared = cadinterp_fuzz::load_le64(data + 16);
    if (declared >= 48 && declared < size) asset_size = static_cast<std::size_t>(declared);
  }
  std::vector<std::uint8_t> bytes(data, data + asset_size);
  cadinterp_fuzz::fix_checksums(bytes);
  FuzzedDataProvider in(data + asset_size, size - asset_size);
  const bool scripted = size > asset_size;

  Script script;
  if (scripted) {
    script.open_mode = static_cast<OpenMode>(in.ConsumeIntegralInRange(0, 2));
    script.misalign = in.ConsumeIntegralInRange(1, 7);
  }
  cadinterp_asset* asset = nullptr;
  cadinterp_status st;
  std::vector<std::uint8_t> shifted;
  if (script.open_mode == OpenMode::CopyThenFree) {
    // The reader must not keep pointers into bytes it was told to copy: they die here.
    std::vector<std::uint8_t> temporary(bytes);
    st = cadinterp_open_memory(temporary.data(), temporary.size(), 1, &asset);
  } else if (script.open_mode == OpenMode::Misaligned) {
    shifted.assign(bytes.size() + 8, 0);
    std::memcpy(shifted.data() + script.misalign, bytes.data(), bytes.size());
    st = cadinterp_open_memory(shifted.data() + script.misalign, bytes.size(), 0, &asset);
  } else {
    st = cadinterp_open_memory(bytes.data(), bytes.size(), 0, &asset);
  }
  if (st != CADINTERP_OK) {
    CHECK(asset == nullptr, "open wrote its output on failure");
    CHECK(st != CADINTERP_E_INTERNAL, "open: internal error: %s", cadinterp_open_error());
    CHECK(*cadinterp_open_error() != '\0', "open failed (%s) without a message", name(st));
    return 0;
  }
  CHECK(asset != nullptr, "open succeeded without an asset");

  // The index verified at open, read from our own 8-aligned copy for cross-checks.
  const cadinterp::fb::Asset* index = cadinterp::fb::GetAsset(bytes.data() + 48);
  Run run(asset, index);
  run.queries();
  if (scripted) {
    parse_points_and_rest(in, run.box(), cadinterp_field_count(asset), script);
  } else {
    const Script d = default_script(run.box(), cadinterp_field_count(asset));
    script.points = d.points;
    script.budgets = d.budgets;
    script.fields = d.fields;
    script.field_count = d.field_count;
  }
  run.points(script);
  cadinterp_close(asset);
  return 0;
}
