// The per-point error estimates (cadinterp_error_estimates, format 1.3 ElementMeshes.error_model)
// on assets the builder writes from the analytic host: the C ABI's contract (geometry and fields
// separate, INFEASIBLE in infeasible elements, argument checks), assets without a model, and the
// calibration against the host's closed-form fields at random points.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "builder/builder_e2e.h"
#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_builder.h"
#include "cadinterp_generated.h"
#include "format/asset_reader.h"
#include "format/asset_writer.h"
#include "format/error_model.h"
#include "format/synthetic_asset.h"

namespace {

using namespace cadinterp;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("cadinterp_errest_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

const cadinterp_host* analytic(const char* model, const char* options) {
  const char* err = nullptr;
  const cadinterp_host* h = cadinterp_host_entry(model, options, &err);
  if (!h) ADD_FAILURE() << model << ": " << (err ? err : "?");
  return h;
}

// Builds `model` with `samples` samples of degree `degree` into a temporary file.
std::string build(const cadinterp_host* h, const std::string& name, int samples, int degree) {
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = samples;
  o.degree = degree;
  o.threads = 2;
  const std::string path = temp_path(name);
  const builder::BuildOutcome b = builder::build_asset(*h, o, path);
  EXPECT_EQ(b.status, CADINTERP_OK) << b.error;
  return path;
}

struct AssetCloser {
  void operator()(cadinterp_asset* a) const { cadinterp_close(a); }
};
using AssetPtr = std::unique_ptr<cadinterp_asset, AssetCloser>;

AssetPtr open(const std::string& path) {
  cadinterp_asset* a = nullptr;
  EXPECT_EQ(cadinterp_open(path.c_str(), &a), CADINTERP_OK) << cadinterp_open_error();
  return AssetPtr(a);
}

// `model` (host options `options`) built linear with `samples` samples into a temporary file
// (its path in `path`), opened; null after a failure was reported.
AssetPtr build_and_open(const char* model, const char* options, int samples, std::string& path) {
  const cadinterp_host* h = analytic(model, options);
  if (!h) return nullptr;
  path = build(h, std::string(model) + ".cadi", samples, 1);
  return open(path);
}

// The plate (K = 3, three per-vertex fields with closed forms) at a small budget: the estimate
// has one entry per quantity, the geometry's is cadinterp_error_estimate's, and geometry and
// fields are measured apart (the plate's geometry is multilinear in its parameters, so
// interpolation reproduces it up to the mapping, while its fields are not).
TEST(ErrorEstimates, GeometryAndFieldsSeparatelyPerPoint) {
  std::string path;
  const AssetPtr a = build_and_open("plate", "edge=8", 40, path);
  ASSERT_TRUE(a);
  const int fields = cadinterp_field_count(a.get());
  ASSERT_GT(fields, 0);
  cadinterp_parameter_info p[3];
  for (int d = 0; d < 3; ++d) ASSERT_EQ(cadinterp_parameter(a.get(), d, &p[d]), CADINTERP_OK);
  double geometry_max = 0, field_max = 0;
  for (int i = 0; i < 50; ++i) {
    double x[3];
    for (int d = 0; d < 3; ++d)
      x[d] = p[d].lower +
             (p[d].upper - p[d].lower) * std::fmod(0.137 + 0.61803 * (i + 1) * (d + 1), 1.0);
    std::vector<double> out(static_cast<std::size_t>(1 + fields), -5);
    int count = 0;
    ASSERT_EQ(cadinterp_error_estimates(a.get(), x, out.data(), 1 + fields, &count), CADINTERP_OK);
    EXPECT_EQ(count, 1 + fields);
    double geometry = -5;
    ASSERT_EQ(cadinterp_error_estimate(a.get(), x, &geometry), CADINTERP_OK);
    EXPECT_EQ(geometry, out[0]);
    for (double e : out) EXPECT_GE(e, 0);
    geometry_max = std::max(geometry_max, out[0]);
    for (int f = 1; f <= fields; ++f)
      field_max = std::max(field_max, out[static_cast<std::size_t>(f)]);
  }
  EXPECT_GT(field_max, 10 * geometry_max) << "the fields' estimates are not the geometry's";
  EXPECT_GT(field_max, 0);
  std::filesystem::remove(path);
}

TEST(ErrorEstimates, ArgumentsDomainAndInfeasibleElements) {
  std::string path;
  const AssetPtr a = build_and_open("bracket", "cells=1,fail_region=1", 60, path);
  ASSERT_TRUE(a);
  const int want = 1 + cadinterp_field_count(a.get());
  std::vector<double> out(static_cast<std::size_t>(want), -5);
  int count = -1;
  double lo[4], hi[4];
  for (int d = 0; d < 4; ++d) {
    cadinterp_parameter_info info;
    ASSERT_EQ(cadinterp_parameter(a.get(), d, &info), CADINTERP_OK);
    lo[d] = info.lower;
    hi[d] = info.upper;
  }
  const double ok[4] = {lo[0], lo[1], (lo[2] + hi[2]) / 2, (lo[3] + hi[3]) / 2};
  // Sizing call, too small a buffer, NULL arguments: count is still reported, out untouched.
  EXPECT_EQ(cadinterp_error_estimates(a.get(), ok, nullptr, 0, &count),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(count, want);
  count = -1;
  EXPECT_EQ(cadinterp_error_estimates(a.get(), ok, out.data(), want - 1, &count),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(count, want);
  EXPECT_EQ(out[0], -5);
  EXPECT_EQ(cadinterp_error_estimates(nullptr, ok, out.data(), want, &count),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_error_estimates(a.get(), nullptr, out.data(), want, &count),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_error_estimates(a.get(), ok, out.data(), want, nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_error_estimate(a.get(), ok, nullptr), CADINTERP_E_INVALID_ARGUMENT);
  // Outside the box.
  const double outside[4] = {hi[0] + 1, lo[1], lo[2], lo[3]};
  EXPECT_EQ(cadinterp_error_estimates(a.get(), outside, out.data(), want, &count),
            CADINTERP_E_OUTSIDE_DOMAIN);
  double e = -5;
  EXPECT_EQ(cadinterp_error_estimate(a.get(), outside, &e), CADINTERP_E_OUTSIDE_DOMAIN);
  EXPECT_EQ(e, -5);
  EXPECT_EQ(out[0], -5);
  // The host fails where the first two parameters are in the top quarter: that corner's
  // elements are infeasible, and have no estimate.
  const double bad[4] = {hi[0], hi[1], hi[2], hi[3]};
  int element = -1, feasible = -1;
  ASSERT_EQ(cadinterp_locate(a.get(), bad, &element, &feasible), CADINTERP_OK);
  ASSERT_EQ(feasible, 0);
  EXPECT_EQ(cadinterp_error_estimates(a.get(), bad, out.data(), want, &count),
            CADINTERP_E_INFEASIBLE);
  EXPECT_EQ(cadinterp_error_estimate(a.get(), bad, &e), CADINTERP_E_INFEASIBLE);
  EXPECT_EQ(e, -5);
  EXPECT_EQ(out[0], -5);
  // A feasible point answers.
  ASSERT_EQ(cadinterp_error_estimates(a.get(), ok, out.data(), want, &count), CADINTERP_OK);
  EXPECT_GE(out[0], 0);
  std::filesystem::remove(path);
}

// An asset without the builder's error model (as every asset written before format 1.3): it
// opens, its estimates are unknown (-1) and cadinterp_error_estimate answers its stored value.
TEST(ErrorEstimates, AssetsWithoutAModelOpenAndReportUnknown) {
  format::SyntheticSpec s;
  s.K = 2;
  s.fields = true;
  const format::SyntheticAsset syn = format::make_synthetic_asset(s);
  const std::vector<std::uint8_t> bytes = format::write_asset(syn.content, {});
  ASSERT_EQ(bytes[10], 0) << "a model-free asset is written as format 1.0";
  cadinterp_asset* raw = nullptr;
  ASSERT_EQ(cadinterp_open_memory(bytes.data(), bytes.size(), 1, &raw), CADINTERP_OK);
  const AssetPtr a(raw);
  const double x[2] = {0.3, 0.6};
  const int want = 1 + cadinterp_field_count(a.get());
  std::vector<double> out(static_cast<std::size_t>(want), -5);
  int count = 0;
  ASSERT_EQ(cadinterp_error_estimates(a.get(), x, out.data(), want, &count), CADINTERP_OK);
  for (double e : out) EXPECT_EQ(e, -1);
  int element = -1;
  ASSERT_EQ(cadinterp_locate(a.get(), x, &element, nullptr), CADINTERP_OK);
  double e = -5;
  ASSERT_EQ(cadinterp_error_estimate(a.get(), x, &e), CADINTERP_OK);
  EXPECT_EQ(e, syn.content.elements[static_cast<std::size_t>(element)].error_estimate);
}

// A K = 2 synthetic asset of `degree` with fields whose feasible elements all have the same
// error model row, 0.01, for every quantity.
format::SyntheticAsset modelled_synthetic(core::Degree degree = core::Degree::Linear) {
  format::SyntheticSpec s;
  s.K = 2;
  s.degree = degree;
  s.fields = true;
  s.tolerance = 1e-5;  // refined past the start grid: a cubic asset has cubic elements
  s.max_samples = 60;
  format::SyntheticAsset syn = format::make_synthetic_asset(s);
  const std::size_t rows = 1 + syn.content.fields.size();
  for (format::ElementData& ed : syn.content.elements)
    if (ed.vertex_count > 0) ed.error_model.assign(rows * 3, 0.01);
  return syn;
}

// cadinterp_error_estimates of the asset `c` writes (opened from a copy of its bytes) at three
// points, one of them a corner of the box, where the linear shape is 0.
std::vector<std::vector<double>> estimates_at_three_points(const format::AssetContent& c) {
  const std::vector<std::uint8_t> bytes = format::write_asset(c, {});
  cadinterp_asset* raw = nullptr;
  EXPECT_EQ(cadinterp_open_memory(bytes.data(), bytes.size(), 1, &raw), CADINTERP_OK);
  const AssetPtr a(raw);
  std::vector<std::vector<double>> out;
  for (const auto& x : std::vector<std::vector<double>>{{0.3, 0.6}, {0.0, 0.0}, {0.71, 0.12}}) {
    out.emplace_back(1 + c.fields.size(), -5.0);
    int count = 0;
    EXPECT_EQ(cadinterp_error_estimates(a.get(), x.data(), out.back().data(),
                                        static_cast<int>(out.back().size()), &count),
              CADINTERP_OK);
  }
  return out;
}

// The geometry floor (format 1.3 ElementMeshes.geometry_floor), the geometry's error at the
// element's own samples, adds to the geometry's estimate everywhere in the element, also at
// its corners where the shape is 0, and to no field's.
TEST(ErrorEstimates, GeometryFloorAddsToTheGeometryOnly) {
  format::SyntheticAsset syn = modelled_synthetic();
  for (format::ElementData& ed : syn.content.elements)
    if (ed.vertex_count > 0) ed.geometry_floor = 0.25;
  for (const std::vector<double>& out : estimates_at_three_points(syn.content)) {
    ASSERT_GT(out.size(), 1u);
    for (std::size_t f = 1; f < out.size(); ++f) {
      EXPECT_GE(out[f], 0);
      EXPECT_NEAR(out[0], out[f] + 0.25, 1e-12) << "field " << f;
    }
  }
}

// On a cubic element (off its corner fallback) the constant estimate is the largest error the
// builder measured, against the host's own meshes, so it already holds the geometry floor's
// difference of two meshes: the floor bounds it from below instead of adding to it. A
// corner-fallback element takes the linear model and adds it (this synthetic asset may have
// none; CornerFallbackElementsEstimateAsLinearOnes builds some).
TEST(ErrorEstimates, GeometryFloorBoundsACubicConstantFromBelow) {
  for (const double floor : {0.25, 0.001}) {
    format::SyntheticAsset syn = modelled_synthetic(core::Degree::Cubic);
    for (format::ElementData& ed : syn.content.elements)
      if (ed.vertex_count > 0) ed.geometry_floor = floor;
    const std::vector<std::uint8_t> bytes = format::write_asset(syn.content, {});
    cadinterp_asset* raw = nullptr;
    ASSERT_EQ(cadinterp_open_memory(bytes.data(), bytes.size(), 1, &raw), CADINTERP_OK);
    const AssetPtr a(raw);
    const int want = 1 + cadinterp_field_count(a.get());
    ASSERT_GT(want, 1);
    int cubic = 0;
    for (int i = 0; i <= 8; ++i)
      for (int j = 0; j <= 8; ++j) {
        const double x[2] = {i / 8.0, j / 8.0};
        int e = -1, feasible = 0, terms = 0, count = 0;
        ASSERT_EQ(cadinterp_locate(a.get(), x, &e, &feasible), CADINTERP_OK);
        if (!feasible) continue;
        ASSERT_EQ(cadinterp_element_term_count(a.get(), e, &terms), CADINTERP_OK);
        std::vector<double> out(static_cast<std::size_t>(want), -5);
        ASSERT_EQ(cadinterp_error_estimates(a.get(), x, out.data(), want, &count), CADINTERP_OK);
        // Every row is 0.01: the field's estimate is the geometry's before its floor.
        const double shaped = out[1];
        ASSERT_GE(shaped, 0);
        // A corner-fallback element's terms are exactly its 2^K corners.
        if (terms != 4) {
          ++cubic;
          EXPECT_NEAR(out[0], std::max(shaped, floor), 1e-12) << x[0] << ", " << x[1];
        } else {
          EXPECT_NEAR(out[0], shaped + floor, 1e-12) << x[0] << ", " << x[1];
        }
      }
    EXPECT_GT(cubic, 0);
  }
}

// The field floors (format 1.3 ElementMeshes.field_floors) add, unscaled, to their own field's
// estimate everywhere in the element, also at its corners where the shape is 0, and to nothing
// else; an element without them estimates as before.
TEST(ErrorEstimates, FieldFloorsAddToTheirFieldOnly) {
  format::SyntheticAsset syn = modelled_synthetic();
  const std::vector<std::vector<double>> without = estimates_at_three_points(syn.content);
  for (format::ElementData& ed : syn.content.elements)
    if (ed.vertex_count > 0)
      for (std::size_t f = 0; f < syn.content.fields.size(); ++f)
        ed.field_floors.push_back(0.25 * static_cast<double>(f + 1));
  const std::vector<std::vector<double>> with = estimates_at_three_points(syn.content);
  for (std::size_t p = 0; p < with.size(); ++p) {
    ASSERT_GT(with[p].size(), 1u);
    EXPECT_EQ(with[p][0], without[p][0]) << "the geometry's estimate has its own floor";
    for (std::size_t f = 1; f < with[p].size(); ++f) {
      EXPECT_GE(without[p][f], 0);
      EXPECT_NEAR(with[p][f], without[p][f] + 0.25 * static_cast<double>(f), 1e-12)
          << "field " << f << " at point " << p;
    }
  }
}

// Per element with a model, (its smallest measured error of field f, its floor of field f), the
// floor -1 where the file holds none; `cubic_floored` counts cubic elements with floors.
struct FloorsOfField {
  std::vector<std::pair<double, double>> elements;
  int cubic_floored = 0;
};
FloorsOfField floors_of_field(const std::string& path, int f) {
  FloorsOfField out;
  const auto r = format::AssetReader::open_file(path);
  const int K = r->basis().dim();
  const auto* els = r->index().elements();
  for (flatbuffers::uoffset_t e = 0; e < els->size(); ++e) {
    const auto* m = els->Get(e);
    if (!m->error_model()) continue;
    const double* row = m->error_model()->data() + static_cast<std::size_t>((1 + f) * (K + 1));
    double smallest = row[0];
    for (int d = 1; d <= K; ++d)
      if (row[d] >= 0) smallest = std::min(smallest, row[d]);
    const double floor =
        m->field_floors() ? m->field_floors()->Get(static_cast<flatbuffers::uoffset_t>(f)) : -1;
    out.elements.emplace_back(smallest, floor);
    if (floor >= 0 && r->basis().element_cubic(static_cast<int>(e))) ++out.cubic_floored;
  }
  return out;
}

// The builder's field floors (SPEC.md "Error model"): on the plate, whose samples are meshed
// apart and mapped (§6), every linear element holds the same floor per field, the lower quartile
// of the elements' smallest measured errors; on the bracket, whose samples share one mesh, and on
// the plate's cubic elements, none.
TEST(ErrorEstimates, FieldFloorsOnLinearElementsWithMappedTerms) {
  const cadinterp_host* plate = analytic("plate", "edge=8");
  const cadinterp_host* bracket = analytic("bracket", "cells=1");
  ASSERT_TRUE(plate && bracket);
  const std::string linear = build(plate, "floors_linear.cadi", 60, 1);
  int floored_fields = 0;
  for (int f = 0; f < 3; ++f) {
    const FloorsOfField got = floors_of_field(linear, f);
    std::vector<double> smallest;  // of the elements with floors
    double floor = -1;
    for (const auto& [m, v] : got.elements) {
      if (v < 0) continue;
      if (floor < 0) floor = v;
      EXPECT_EQ(v, floor) << "field " << f << ": one floor for the asset";
      smallest.push_back(m);
    }
    ASSERT_GE(2 * smallest.size(), got.elements.size()) << "most plate elements are mapped";
    // The lower quartile: fewer than a quarter of them measured less, more than a quarter no
    // more than the floor.
    const auto n = static_cast<std::ptrdiff_t>(smallest.size());
    const auto below =
        std::count_if(smallest.begin(), smallest.end(), [&](double m) { return m < floor; });
    const auto at_most =
        std::count_if(smallest.begin(), smallest.end(), [&](double m) { return m <= floor; });
    EXPECT_LT(4 * below, n) << "field " << f;
    EXPECT_GT(4 * at_most, n) << "field " << f;
    floored_fields += floor > 0;
  }
  EXPECT_GT(floored_fields, 0) << "the plate's mapped fields have floors";
  const std::string unmapped = build(bracket, "floors_bracket.cadi", 40, 1);
  for (const auto& [smallest, v] : floors_of_field(unmapped, 0).elements)
    EXPECT_EQ(v, -1) << "a bracket element has floors (smallest error " << smallest << ")";
  const std::string cubic = build(plate, "floors_cubic.cadi", 60, 3);
  EXPECT_EQ(floors_of_field(cubic, 0).cubic_floored, 0);
  for (const std::string& p : {linear, unmapped, cubic}) std::filesystem::remove(p);
}

// A cubic build that stops at its start grid next to a failed corner: every cubic term reaches
// every sample there, so each element whose corners are feasible is on its corner fallback and
// interpolates exactly as the linear build does. Its error model is then measured and shaped as
// a linear element's (SPEC.md "Error model"), so the two assets estimate alike at every point;
// a constant cubic estimate over a multilinear interpolant overstated the press's geometry
// error 3.4x at the median.
TEST(ErrorEstimates, CornerFallbackElementsEstimateAsLinearOnes) {
  const cadinterp_host* h = analytic("bracket", "cells=1,fail_region=1");
  ASSERT_NE(h, nullptr);
  const std::string lpath = build(h, "fallback_linear.cadi", 8, 1);
  const std::string cpath = build(h, "fallback_cubic.cadi", 8, 3);
  const AssetPtr linear = open(lpath), cubic = open(cpath);
  ASSERT_TRUE(linear && cubic);
  const int want = 1 + cadinterp_field_count(linear.get());
  ASSERT_EQ(want, 1 + cadinterp_field_count(cubic.get()));
  cadinterp_parameter_info p[4];
  for (int d = 0; d < 4; ++d) ASSERT_EQ(cadinterp_parameter(linear.get(), d, &p[d]), CADINTERP_OK);
  int compared = 0;
  for (int i = 0; i < 200; ++i) {
    double x[4];
    for (int d = 0; d < 4; ++d)
      x[d] = p[d].lower +
             (p[d].upper - p[d].lower) * std::fmod(0.137 + 0.61803 * (i + 1) * (d + 1), 1.0);
    int el = -1, ef = -1, ce = -1, cf = -1;
    ASSERT_EQ(cadinterp_locate(linear.get(), x, &el, &ef), CADINTERP_OK);
    ASSERT_EQ(cadinterp_locate(cubic.get(), x, &ce, &cf), CADINTERP_OK);
    EXPECT_EQ(ef, cf) << "at point " << i;
    if (!ef || !cf) continue;
    int terms = 0;
    ASSERT_EQ(cadinterp_element_term_count(cubic.get(), ce, &terms), CADINTERP_OK);
    EXPECT_EQ(terms, 16) << "a cubic element off its corner fallback at point " << i;
    std::vector<double> le(static_cast<std::size_t>(want)), cest(le.size());
    int count = 0;
    ASSERT_EQ(cadinterp_error_estimates(linear.get(), x, le.data(), want, &count), CADINTERP_OK);
    ASSERT_EQ(cadinterp_error_estimates(cubic.get(), x, cest.data(), want, &count), CADINTERP_OK);
    for (int q = 0; q < want; ++q)
      EXPECT_NEAR(cest[static_cast<std::size_t>(q)], le[static_cast<std::size_t>(q)],
                  1e-9 * std::max(1.0, le[static_cast<std::size_t>(q)]))
          << "quantity " << q << " at point " << i;
    ++compared;
  }
  EXPECT_GT(compared, 100);
  std::filesystem::remove(lpath);
  std::filesystem::remove(cpath);
}

// What the builder stores as an element's centre error (ElementMeshes.error_model) is the
// asset's true error at that centre: each per-vertex field at the evaluated vertices against the
// host's field located in its own tets there, as measure_accuracy compares them at random points.
// The plate's terms are mapped (§6) onto the centre's mesh, and a mapped vertex slides within
// its face, so a comparison vertex by vertex with the centre's own mesh measured the field's
// gradient times that slide as error. Without canonical refinement the stored meshes are the
// ones the builder measured.
TEST(ErrorEstimates, CentreErrorIsTheAssetsTrueErrorThere) {
  const cadinterp_host* h = analytic("plate", "edge=8");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  o.max_samples = 60;
  o.threads = 2;
  o.canonical_refinement = 0;
  const std::string path = temp_path("plate_centres.cadi");
  const builder::BuildOutcome b = builder::build_asset(*h, o, path);
  ASSERT_EQ(b.status, CADINTERP_OK) << b.error;
  // Each modelled element's centre and stored centre errors (geometry, then the fields).
  std::vector<std::vector<double>> centres, stored;
  std::vector<std::string> fields;  // the index's, in its order
  {
    const auto r = format::AssetReader::open_file(path);
    for (const auto* f : *r->index().fields()) fields.push_back(f->name()->str());
    const int K = r->basis().dim();
    const auto* params = r->index().parameters();
    const auto* box = r->index().basis()->elem_box();
    const auto* els = r->index().elements();
    for (flatbuffers::uoffset_t e = 0; e < els->size(); ++e) {
      const auto* m = els->Get(e);
      if (!m->error_model()) continue;
      std::vector<double> x(static_cast<std::size_t>(K)), row;
      for (int d = 0; d < K; ++d) {
        const auto* p = params->Get(static_cast<flatbuffers::uoffset_t>(d));
        const double lo = box->Get(2 * K * e + d), hi = box->Get(2 * K * e + K + d);
        x[static_cast<std::size_t>(d)] = p->lower() + (p->upper() - p->lower()) * (lo + hi) / 2;
      }
      for (flatbuffers::uoffset_t i = 0; i < m->error_model()->size(); i += K + 1)
        row.push_back(m->error_model()->Get(i));
      centres.push_back(x);
      stored.push_back(row);
    }
  }
  ASSERT_GE(centres.size(), 4u);
  const mesh::Host host(*h);
  const builder::AccuracyReport r = builder::measure_accuracy_at(path, host, centres, true, 2);
  ASSERT_EQ(r.per_point.size(), centres.size());
  ASSERT_EQ(r.field_names.size(), 2u) << "the plate's per-vertex fields";
  int compared = 0;
  for (std::size_t i = 0; i < centres.size(); ++i) {
    const auto& p = r.per_point[i];
    ASSERT_EQ(p.x, centres[i]);
    ASSERT_EQ(p.error.size(), 1 + r.field_names.size());
    for (std::size_t k = 0; k < r.field_names.size(); ++k) {
      const auto f = std::find(fields.begin(), fields.end(), r.field_names[k]) - fields.begin();
      const double want = stored[i][1 + static_cast<std::size_t>(f)];
      // Float storage of the asset's positions and values: about 1e-7 of a field's range.
      EXPECT_NEAR(p.error[1 + k], want, 1e-5 + 1e-3 * want)
          << r.field_names[k] << " at the centre of modelled element " << i;
      compared += want > 1e-4;
    }
  }
  EXPECT_GT(compared, static_cast<int>(centres.size())) << "the fields err at the centres";
  std::filesystem::remove(path);
}

// Calibration against a host whose truth is a closed form: at 200 random points (other points
// than the calibration's), the estimate bounds the true error (geometry: the Hausdorff distance
// to the host's mesh at x; fields: against the host's closed-form values on its mesh at x, the
// comparison the builder's own measurements make) at >= 90 % of the points, and the fields'
// estimates are within 3x of it at the median. (The geometry's true error is float rounding
// on this model, whose boundary the interpolation reproduces, so its ratio is not bounded.)
TEST(ErrorEstimates, BoundTheTrueErrorAtMostPoints) {
  const cadinterp_host* h = analytic("plate", "edge=8");
  ASSERT_NE(h, nullptr);
  const std::string path = build(h, "plate_calibration.cadi", 120, 1);
  const mesh::Host host(*h);
  const builder::AccuracyReport r = builder::measure_accuracy(path, host, 200, 3);
  ASSERT_EQ(r.estimate_points.size(), 1 + r.field_names.size());
  for (std::size_t q = 0; q < r.estimate_points.size(); ++q) {
    const std::string name = q ? r.field_names[q - 1] : "geometry";
    std::printf(
        "[ figures ] %s: bounded at %.1f %% of %d points, estimate / error: median %.2f, 10th "
        "percentile %.2f\n",
        name.c_str(), 100 * r.estimate_coverage[q], r.estimate_points[q],
        r.estimate_median_ratio[q], r.estimate_p10_ratio[q]);
    EXPECT_GE(r.estimate_points[q], 190) << name;
    EXPECT_GE(r.estimate_coverage[q], 0.9) << name;
    if (q) {
      EXPECT_LE(r.estimate_median_ratio[q], 3.0) << name;
    }
  }
  // The per-point records are the pairs those figures are made of: one per compared point, the
  // estimate the ABI gives at that x, and together the same counts and coverage.
  ASSERT_EQ(r.per_point.size(), 200u);
  const AssetPtr a = open(path);
  std::vector<int> slot{0};  // quantity q's place in cadinterp_error_estimates' output
  for (const std::string& name : r.field_names)
    for (int i = 0; i < cadinterp_field_count(a.get()); ++i) {
      cadinterp_field_info info{};
      ASSERT_EQ(cadinterp_field(a.get(), i, &info), CADINTERP_OK);
      if (name == info.name) slot.push_back(1 + i);
    }
  ASSERT_EQ(slot.size(), r.estimate_points.size());
  std::vector<int> n(slot.size(), 0), covered(slot.size(), 0);
  for (const auto& p : r.per_point) {
    ASSERT_EQ(p.x.size(), 3u);
    ASSERT_EQ(p.estimate.size(), n.size());
    ASSERT_EQ(p.error.size(), n.size());
    std::vector<double> est(8);
    int count = 0;
    ASSERT_EQ(cadinterp_error_estimates(a.get(), p.x.data(), est.data(), 8, &count), CADINTERP_OK);
    for (std::size_t q = 0; q < n.size(); ++q) {
      EXPECT_EQ(p.estimate[q], est[static_cast<std::size_t>(slot[q])]);
      if (p.estimate[q] < 0) continue;
      ++n[q];
      covered[q] += p.estimate[q] >= p.error[q] ? 1 : 0;
    }
  }
  for (std::size_t q = 0; q < n.size(); ++q) {
    EXPECT_EQ(n[q], r.estimate_points[q]);
    EXPECT_DOUBLE_EQ(static_cast<double>(covered[q]) / n[q], r.estimate_coverage[q]);
  }
  std::filesystem::remove(path);
}

// cadinterp_build_options::calibration_points on the plate: the build asks the host at held-out
// points before its element stage, reports the factors and floors, records the option,
// multiplies every element's model by its quantity's factor and adds its floor (the samples and
// meshes are those of the same build without calibration). The calibrated estimates are then
// checked against the host at other random points: where a factor or floor changed, the estimate
// still bounds the true error at >= 90 % of them.
TEST(ErrorCalibration, HeldOutPointsScaleEveryElementsModel) {
  const cadinterp_host* h = analytic("plate", "edge=8");
  ASSERT_NE(h, nullptr);
  cadinterp_build_options o;
  cadinterp_build_options_init(&o);
  EXPECT_EQ(o.calibration_points, 0);
  for (int bad : {-1, 100001}) {
    cadinterp_build_options b = o;
    b.calibration_points = bad;
    cadinterp_builder* raw = nullptr;
    EXPECT_EQ(cadinterp_builder_create(h, &b, &raw), CADINTERP_E_INVALID_ARGUMENT) << bad;
    EXPECT_EQ(raw, nullptr);
    EXPECT_NE(std::string(cadinterp_builder_create_error()).find("calibration_points"),
              std::string::npos);
  }
  o.max_samples = 60;
  o.threads = 2;
  const std::string plain = temp_path("plate_plain.cadi"), calibrated = temp_path("plate_cal.cadi");
  const builder::BuildOutcome a = builder::build_asset(*h, o, plain);
  ASSERT_EQ(a.status, CADINTERP_OK) << a.error;
  EXPECT_TRUE(a.calibration.empty());
  EXPECT_TRUE(a.calibration_floors.empty());
  EXPECT_EQ(a.stages.calibrated_points, 0);
  o.calibration_points = 60;
  const builder::BuildOutcome b = builder::build_asset(*h, o, calibrated);
  ASSERT_EQ(b.status, CADINTERP_OK) << b.error;
  EXPECT_EQ(b.report.samples, a.report.samples);
  // Points in refused elements are not asked; the plate refuses none.
  EXPECT_EQ(b.report.host_evaluations, a.report.host_evaluations + 60);
  EXPECT_EQ(b.stages.calibrated_points, 60);
  EXPECT_EQ(b.stages.points_requested, a.stages.points_requested);
  ASSERT_EQ(b.calibration.size(), 4u) << "geometry and the plate's three fields";
  ASSERT_EQ(b.calibration_floors.size(), 4u);
  bool changed = false;
  for (double c : b.calibration) {
    EXPECT_GE(c, 1 / format::kErrorModelSafetyLinear);
    changed = changed || c != 1.0;
  }
  EXPECT_TRUE(changed) << "the plate's geometry estimate overstates by orders of magnitude";

  const auto ra = format::AssetReader::open_file(plain);
  const auto rb = format::AssetReader::open_file(calibrated);
  EXPECT_NE(
      std::string(rb->index().provenance()->options()->c_str()).find("\"calibration_points\":60"),
      std::string::npos);
  const int K = ra->basis().dim();
  const auto* ea = ra->index().elements();
  const auto* eb = rb->index().elements();
  ASSERT_EQ(ea->size(), eb->size());
  int modelled = 0;
  for (flatbuffers::uoffset_t e = 0; e < ea->size(); ++e) {
    const auto *ma = ea->Get(e), *mb = eb->Get(e);
    ASSERT_EQ(ma->vertex_count(), mb->vertex_count());
    EXPECT_DOUBLE_EQ(mb->geometry_floor(), ma->geometry_floor() + b.calibration_floors[0]);
    if (!ma->error_model()) {
      EXPECT_EQ(mb->error_model(), nullptr);
      continue;
    }
    ++modelled;
    ASSERT_EQ(ma->error_model()->size(), mb->error_model()->size());
    for (flatbuffers::uoffset_t i = 0; i < ma->error_model()->size(); ++i) {
      const double was = ma->error_model()->Get(i), is = mb->error_model()->Get(i);
      const double c = b.calibration[i / static_cast<flatbuffers::uoffset_t>(K + 1)];
      if (was < 0)
        EXPECT_EQ(is, was) << "unknown stays unknown";
      else
        EXPECT_NEAR(is, was * c, 1e-12 * was * c) << "element " << e << ", entry " << i;
    }
  }
  EXPECT_GT(modelled, 4);
  for (flatbuffers::uoffset_t e = 0; e < ea->size(); ++e) {
    const auto *fa = ea->Get(e)->field_floors(), *fb = eb->Get(e)->field_floors();
    if (!ea->Get(e)->error_model()) continue;
    for (std::size_t f = 0; f + 1 < b.calibration_floors.size(); ++f) {
      const double was = fa ? fa->Get(static_cast<flatbuffers::uoffset_t>(f)) : 0.0;
      const double is = fb ? fb->Get(static_cast<flatbuffers::uoffset_t>(f)) : 0.0;
      EXPECT_DOUBLE_EQ(is, was + b.calibration_floors[f + 1]) << "element " << e << ", field " << f;
    }
  }

  // Against the host at 200 other random points (measure_accuracy's seed 3), each quantity
  // whose factor changed.
  std::vector<std::string> fields;  // the index's, in its order
  for (const auto* f : *rb->index().fields()) fields.push_back(f->name()->str());
  const mesh::Host host(*h);
  const builder::AccuracyReport r = builder::measure_accuracy(calibrated, host, 200, 3);
  int checked = 0;
  for (std::size_t q = 0; q < r.estimate_points.size(); ++q) {
    const std::string name = q ? r.field_names[q - 1] : "geometry";
    const std::size_t slot =
        q ? 1 + static_cast<std::size_t>(std::find(fields.begin(), fields.end(), name) -
                                         fields.begin())
          : 0;
    ASSERT_LT(slot, b.calibration.size());
    std::printf(
        "[ figures ] %s: factor %.3f, floor %.3g, bounded at %.1f %% of %d points, median %.2f\n",
        name.c_str(), b.calibration[slot], b.calibration_floors[slot], 100 * r.estimate_coverage[q],
        r.estimate_points[q], r.estimate_median_ratio[q]);
    if (b.calibration[slot] == 1.0 && b.calibration_floors[slot] == 0.0) continue;
    ++checked;
    EXPECT_GE(r.estimate_points[q], 190) << name;
    EXPECT_GE(r.estimate_coverage[q], 0.9) << name;
  }
  EXPECT_GE(checked, 1);
  std::filesystem::remove(plain);
  std::filesystem::remove(calibrated);
}

}  // namespace
