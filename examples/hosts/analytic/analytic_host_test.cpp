// The analytic host's models, tested through the plain functions its callbacks wrap (no builder):
// meshes valid and closed over the parameter box, control points stable, fields finite and
// physical, options and the fail region as documented.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "analytic_host.h"

namespace {

using ModelPtr = std::unique_ptr<analytic_model, decltype(&analytic_model_destroy)>;

ModelPtr make_model(const char* name, const char* options) {
  const char* error = nullptr;
  analytic_model* m = analytic_model_create(name, options, &error);
  EXPECT_NE(m, nullptr) << (error ? error : "");
  return ModelPtr(m, &analytic_model_destroy);
}

struct Mesh {
  analytic_mesh m{};
  Mesh() = default;
  Mesh(const Mesh&) = delete;
  Mesh& operator=(const Mesh&) = delete;
  ~Mesh() { analytic_mesh_free(&m); }
  cadinterp_host_mesh view() const {
    return {m.vertex_count,   m.vertices,  m.tet_count,    m.tets,
            m.triangle_count, m.triangles, m.triangle_tags};
  }
  const double* v(std::size_t i) const { return &m.vertices[3 * i]; }
};

struct References {
  analytic_references r{};
  References() = default;
  References(const References&) = delete;
  References& operator=(const References&) = delete;
  ~References() { analytic_references_free(&r); }
  std::vector<int64_t> id(std::size_t p) const {
    return {r.point_ids + r.point_id_offsets[p], r.point_ids + r.point_id_offsets[p + 1]};
  }
};

using Vec3 = std::array<double, 3>;

Vec3 sub(const double* a, const double* b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

double six_volume(const Mesh& mesh, std::size_t t) {
  const uint32_t* q = &mesh.m.tets[4 * t];
  const double* a = mesh.v(q[0]);
  return dot(sub(mesh.v(q[1]), a), cross(sub(mesh.v(q[2]), a), sub(mesh.v(q[3]), a)));
}

double bbox_diagonal(const Mesh& mesh) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < mesh.m.vertex_count; ++i)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], mesh.v(i)[c]);
      hi[c] = std::max(hi[c], mesh.v(i)[c]);
    }
  const Vec3 d{hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  return std::sqrt(dot(d, d));
}

double point_segment_distance(const double* p, const double* a, const double* b) {
  const Vec3 ab = sub(b, a), ap = sub(p, a);
  const double t = std::clamp(dot(ap, ab) / dot(ab, ab), 0.0, 1.0);
  const Vec3 d{ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
  return std::sqrt(dot(d, d));
}

// The parameter points of a test: every combination of {lower, middle, upper}, plus seeded
// random points.
std::vector<std::vector<double>> parameter_points(const analytic_model* m, int random_points) {
  const int k = analytic_model_parameter_count(m);
  const cadinterp_parameter_desc* p = analytic_model_parameters(m);
  std::vector<std::vector<double>> out;
  int combos = 1;
  for (int i = 0; i < k; ++i) combos *= 3;
  for (int c = 0; c < combos; ++c) {
    std::vector<double> x(static_cast<std::size_t>(k));
    for (int i = 0, r = c; i < k; ++i, r /= 3)
      x[static_cast<std::size_t>(i)] = p[i].lower + 0.5 * (r % 3) * (p[i].upper - p[i].lower);
    out.push_back(x);
  }
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int n = 0; n < random_points; ++n) {
    std::vector<double> x(static_cast<std::size_t>(k));
    for (int i = 0; i < k; ++i)
      x[static_cast<std::size_t>(i)] = p[i].lower + u(rng) * (p[i].upper - p[i].lower);
    out.push_back(x);
  }
  return out;
}

std::set<int32_t> all_tags(const char* model) {
  std::set<int32_t> tags;
  const int count = std::strcmp(model, "bracket") == 0 ? 10 : 6;
  for (int32_t t = 1; t <= count; ++t) tags.insert(t);
  return tags;
}

// Positive tets, boundary = the faces of exactly one tet, oriented outward and closed.
void check_mesh(const Mesh& mesh, const std::set<int32_t>& tags, const std::string& where) {
  SCOPED_TRACE(where);
  const analytic_mesh& m = mesh.m;
  ASSERT_GT(m.vertex_count, 0u);
  ASSERT_GT(m.tet_count, 0u);
  for (std::size_t i = 0; i < 3 * m.vertex_count; ++i) ASSERT_TRUE(std::isfinite(m.vertices[i]));
  for (std::size_t i = 0; i < 4 * m.tet_count; ++i) ASSERT_LT(m.tets[i], m.vertex_count);
  for (std::size_t i = 0; i < 3 * m.triangle_count; ++i) ASSERT_LT(m.triangles[i], m.vertex_count);

  const double diag = bbox_diagonal(mesh);
  double min_vol = 1e300, volume = 0.0;
  std::map<std::array<uint32_t, 3>, int> faces;  // sorted tet faces and how many tets have them
  static const int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (std::size_t t = 0; t < m.tet_count; ++t) {
    const double v = six_volume(mesh, t);
    min_vol = std::min(min_vol, v);
    volume += v / 6.0;
    for (const auto& f : kFace) {
      std::array<uint32_t, 3> key{m.tets[4 * t + f[0]], m.tets[4 * t + f[1]], m.tets[4 * t + f[2]]};
      std::sort(key.begin(), key.end());
      ++faces[key];
    }
  }
  // The builder's degeneracy threshold is 1e-12 diag^3 (sample.cpp); be far above it.
  EXPECT_GT(min_vol, 1e-6 * diag * diag * diag) << "inverted or nearly flat tet";

  std::set<std::array<uint32_t, 3>> boundary;
  for (const auto& [key, count] : faces) {
    ASSERT_LE(count, 2) << "non-manifold tet face";
    if (count == 1) boundary.insert(key);
  }
  std::set<std::array<uint32_t, 3>> triangles;
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  double enclosed = 0.0;
  for (std::size_t f = 0; f < m.triangle_count; ++f) {
    const uint32_t* t = &m.triangles[3 * f];
    std::array<uint32_t, 3> key{t[0], t[1], t[2]};
    std::sort(key.begin(), key.end());
    EXPECT_TRUE(triangles.insert(key).second) << "triangle given twice";
    EXPECT_TRUE(tags.count(m.triangle_tags[f])) << "unknown tag " << m.triangle_tags[f];
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
    const Vec3 a{mesh.v(t[0])[0], mesh.v(t[0])[1], mesh.v(t[0])[2]};
    enclosed += dot(a, cross(Vec3{mesh.v(t[1])[0], mesh.v(t[1])[1], mesh.v(t[1])[2]},
                             Vec3{mesh.v(t[2])[0], mesh.v(t[2])[1], mesh.v(t[2])[2]})) /
                6.0;
  }
  EXPECT_EQ(triangles, boundary) << "boundary triangles are not the tets' free faces";
  // Closed and consistently oriented: every edge once in each direction.
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1);
    auto back = directed.find({edge.second, edge.first});
    EXPECT_TRUE(back != directed.end() && back->second == 1) << "open or flipped edge";
  }
  // Outward: the divergence theorem gives +volume only for outward normals.
  EXPECT_NEAR(enclosed, volume, 1e-9 * volume);
  std::set<int32_t> seen(m.triangle_tags, m.triangle_tags + m.triangle_count);
  EXPECT_EQ(seen, tags) << "a B-rep face has no triangle";
}

// Control points on the meshed boundary, IDs unique and well-formed, paths joining consecutive
// points along an edge. Gives the IDs in order.
void check_references(const Mesh& mesh, const References& refs, int levels,
                      const std::string& where, std::vector<std::vector<int64_t>>* out = nullptr) {
  SCOPED_TRACE(where);
  const analytic_references& r = refs.r;
  std::set<std::pair<uint32_t, uint32_t>> edges;
  for (std::size_t f = 0; f < mesh.m.triangle_count; ++f)
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = mesh.m.triangles[3 * f + e], b = mesh.m.triangles[3 * f + (e + 1) % 3];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  const double tol = 1e-9 * bbox_diagonal(mesh);
  auto on_boundary_edge = [&](const double* p) {
    for (const auto& [a, b] : edges)
      if (point_segment_distance(p, mesh.v(a), mesh.v(b)) <= tol) return true;
    return false;
  };

  std::vector<std::vector<int64_t>> ids;
  std::set<std::vector<int64_t>> unique;
  for (std::size_t p = 0; p < r.point_count; ++p) {
    std::vector<int64_t> id = refs.id(p);
    EXPECT_TRUE(unique.insert(id).second) << "duplicate control point ID";
    ASSERT_GE(id.size(), 4u);
    if (id[0] == 0) {
      EXPECT_EQ(id.size(), 5u) << "a block's vertex has three edges";
      EXPECT_TRUE(std::is_sorted(id.begin() + 2, id.end()));
      // A B-rep vertex is a mesh vertex.
      bool found = false;
      for (std::size_t v = 0; v < mesh.m.vertex_count && !found; ++v)
        found = std::memcmp(mesh.v(v), &r.point_positions[3 * p], 3 * sizeof(double)) == 0;
      EXPECT_TRUE(found);
    } else {
      EXPECT_EQ(id[0], 1);
      EXPECT_LT(id[2], id[3]) << "end vertex ids sorted";
      ASSERT_GE(id.size(), 5u);
      EXPECT_EQ(id[4], -1);
      EXPECT_LE(id.size(), 5u + static_cast<std::size_t>(levels) - 1);
      for (std::size_t i = 5; i < id.size(); ++i) EXPECT_TRUE(id[i] == 0 || id[i] == 1);
    }
    EXPECT_TRUE(on_boundary_edge(&r.point_positions[3 * p])) << "control point off the mesh";
    ids.push_back(id);
  }

  const std::size_t per_edge = (std::size_t{1} << levels) - 1;
  const std::size_t vertices = static_cast<std::size_t>(
      std::count_if(ids.begin(), ids.end(), [](const auto& id) { return id[0] == 0; }));
  EXPECT_EQ(r.point_count - vertices, (r.path_count / (per_edge + 1)) * per_edge);
  for (std::size_t q = 0; q < r.path_count; ++q) {
    const std::size_t a = r.path_points[2 * q], b = r.path_points[2 * q + 1];
    ASSERT_LT(a, r.point_count);
    ASSERT_LT(b, r.point_count);
    const std::size_t rows = r.path_offsets[q + 1] - r.path_offsets[q];
    ASSERT_GE(rows, 2u);
    const double* first = &r.path_vertices[3 * r.path_offsets[q]];
    const double* last = &r.path_vertices[3 * (r.path_offsets[q + 1] - 1)];
    EXPECT_EQ(std::memcmp(first, &r.point_positions[3 * a], 3 * sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(last, &r.point_positions[3 * b], 3 * sizeof(double)), 0);
    for (std::size_t i = 0; i < rows; ++i) {
      const double* v = &r.path_vertices[3 * (r.path_offsets[q] + i)];
      EXPECT_TRUE(on_boundary_edge(v)) << "path off the mesh's edges";
      if (i > 0) {
        const Vec3 d = sub(v, v - 3);
        EXPECT_GT(dot(d, d), 0.0) << "repeated path vertex";
      }
    }
    // Both ends on the same B-rep edge.
    const std::vector<int64_t> ia = ids[a], ib = ids[b];
    if (ia[0] == 1 && ib[0] == 1) {
      EXPECT_EQ(ia[1], ib[1]);
    } else if (ia[0] == 1 || ib[0] == 1) {
      const auto& vertex = ia[0] == 0 ? ia : ib;
      const auto& sample = ia[0] == 0 ? ib : ia;
      EXPECT_TRUE(std::find(vertex.begin() + 2, vertex.end(), sample[1]) != vertex.end());
    }
  }
  if (out) *out = ids;
}

void check_fields(const analytic_model* model, const double* x, const Mesh& mesh,
                  const std::string& where) {
  SCOPED_TRACE(where);
  const cadinterp_host_mesh view = mesh.view();
  for (int f = 0; f < analytic_model_field_count(model); ++f) {
    const analytic_field_desc* d = analytic_model_field(model, f);
    const bool per_vertex = d->location == CADINTERP_PER_VERTEX;
    const std::size_t rows = per_vertex ? mesh.m.vertex_count : mesh.m.tet_count;
    std::vector<double> values(rows * static_cast<std::size_t>(d->components));
    const char* message = nullptr;
    ASSERT_EQ(analytic_model_field_values(model, f, x, &view, values.data(), &message),
              CADINTERP_OK);
    for (double v : values) ASSERT_TRUE(std::isfinite(v)) << d->name;
    const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
    if (std::strcmp(d->name, "temperature") == 0) {
      EXPECT_GE(*lo, 15.0);
      EXPECT_LE(*hi, 120.0);
      EXPECT_GT(*hi - *lo, 1.0) << "a field that does not vary tests nothing";
    } else if (std::strcmp(d->name, "von_mises") == 0) {
      EXPECT_GE(*lo, 0.0);
      EXPECT_GT(*hi, 0.5);
      EXPECT_LT(*hi, 1000.0);
    } else if (std::strcmp(d->name, "displacement") == 0) {
      EXPECT_LT(std::max(-*lo, *hi), 50.0);
      EXPECT_GT(std::max(-*lo, *hi), 1e-3);
    }
    // The closed form at each vertex, or at each centroid.
    for (std::size_t i = 0; i < rows; i += 7) {
      double p[3] = {0, 0, 0};
      if (per_vertex) {
        std::memcpy(p, mesh.v(i), sizeof(p));
      } else {
        for (int k = 0; k < 4; ++k)
          for (int c = 0; c < 3; ++c) p[c] += 0.25 * mesh.v(mesh.m.tets[4 * i + k])[c];
      }
      double truth[16];
      ASSERT_EQ(analytic_model_field_at(model, f, x, p, truth), CADINTERP_OK);
      for (int c = 0; c < d->components; ++c)
        EXPECT_EQ(
            truth[c],
            values[i * static_cast<std::size_t>(d->components) + static_cast<std::size_t>(c)]);
    }
  }
}

std::string describe(const char* model, const std::vector<double>& x) {
  std::string s = model;
  for (double v : x) s += " " + std::to_string(v);
  return s;
}

class ModelTest : public ::testing::TestWithParam<const char*> {};

TEST_P(ModelTest, MeshesReferencesAndFieldsAcrossTheBox) {
  const char* name = GetParam();
  ModelPtr model = make_model(name, nullptr);
  std::vector<std::vector<int64_t>> first_ids;
  std::set<std::size_t> vertex_counts;
  for (const auto& x : parameter_points(model.get(), 20)) {
    const std::string where = describe(name, x);
    Mesh mesh;
    const char* message = nullptr;
    ASSERT_EQ(analytic_model_mesh(model.get(), x.data(), &mesh.m, &message), CADINTERP_OK) << where;
    check_mesh(mesh, all_tags(name), where);
    vertex_counts.insert(mesh.m.vertex_count);
    References refs;
    ASSERT_EQ(analytic_model_references(model.get(), x.data(), &refs.r, &message), CADINTERP_OK);
    std::vector<std::vector<int64_t>> ids;
    check_references(mesh, refs, 2, where, &ids);
    if (first_ids.empty())
      first_ids = ids;
    else
      EXPECT_EQ(ids, first_ids) << "control point IDs depend on x: " << where;
    check_fields(model.get(), x.data(), mesh, where);
  }
  if (std::strcmp(name, "bracket") == 0)
    EXPECT_EQ(vertex_counts.size(), 1u) << "the bracket's combinatorics must not change";
  else
    EXPECT_GE(vertex_counts.size(), 5u) << "the plate's resolution must follow its size";
}

INSTANTIATE_TEST_SUITE_P(Analytic, ModelTest, ::testing::Values("bracket", "plate"));

TEST(AnalyticBracket, CountsAndIdsOfTheBRep) {
  ModelPtr model = make_model("bracket", "cells=2,levels=3");
  const double x[4] = {60, 45, 5, 90};
  Mesh mesh;
  References refs;
  ASSERT_EQ(analytic_model_mesh(model.get(), x, &mesh.m, nullptr), CADINTERP_OK);
  // cells=2: 10 x 1 x 2 cells along the strip, through the thickness, across the width
  EXPECT_EQ(mesh.m.vertex_count, 11u * 2u * 3u);
  EXPECT_EQ(mesh.m.tet_count, 6u * 10u * 1u * 2u);
  ASSERT_EQ(analytic_model_references(model.get(), x, &refs.r, nullptr), CADINTERP_OK);
  // 16 vertices, 24 edges with 7 samples each, 8 paths per edge
  EXPECT_EQ(refs.r.point_count, 16u + 24u * 7u);
  EXPECT_EQ(refs.r.path_count, 24u * 8u);
  check_references(mesh, refs, 3, "bracket cells=2 levels=3");
  // The vertex at the flange's end, outer side, z = 0: id 1, edges 1 (width), 9 (thickness),
  // 13 (along the flange).
  EXPECT_EQ(refs.id(0), (std::vector<int64_t>{0, 1, 1, 9, 13}));
  // Its position: the flange's outer surface is y = -t/2.
  EXPECT_EQ(refs.r.point_positions[0], 0.0);
  EXPECT_EQ(refs.r.point_positions[1], -2.5);
  EXPECT_EQ(refs.r.point_positions[2], 0.0);
}

TEST(AnalyticBracket, PositionsAreSmoothAndNonlinearInX) {
  ModelPtr model = make_model("bracket", nullptr);
  const double a[4] = {60, 45, 5, 60}, b[4] = {60, 45, 5, 120}, mid[4] = {60, 45, 5, 90};
  Mesh ma, mb, mm;
  ASSERT_EQ(analytic_model_mesh(model.get(), a, &ma.m, nullptr), CADINTERP_OK);
  ASSERT_EQ(analytic_model_mesh(model.get(), b, &mb.m, nullptr), CADINTERP_OK);
  ASSERT_EQ(analytic_model_mesh(model.get(), mid, &mm.m, nullptr), CADINTERP_OK);
  double deviation = 0.0;
  for (std::size_t i = 0; i < 3 * mm.m.vertex_count; ++i)
    deviation = std::max(deviation,
                         std::fabs(mm.m.vertices[i] - 0.5 * (ma.m.vertices[i] + mb.m.vertices[i])));
  EXPECT_GT(deviation, 1.0) << "mm: linear interpolation must not be exact";

  // Small steps in every parameter move vertices by amounts of the step's order.
  const double h = 1e-4;
  for (int k = 0; k < 4; ++k) {
    double xp[4] = {60, 45, 5, 90};
    xp[k] += h;
    Mesh mp;
    ASSERT_EQ(analytic_model_mesh(model.get(), xp, &mp.m, nullptr), CADINTERP_OK);
    double change = 0.0;
    for (std::size_t i = 0; i < 3 * mm.m.vertex_count; ++i)
      change = std::max(change, std::fabs(mp.m.vertices[i] - mm.m.vertices[i]));
    EXPECT_LT(change, 10 * h) << "parameter " << k;
    EXPECT_GT(change, 0.0) << "parameter " << k;
  }
}

TEST(AnalyticBracket, StressAtTheClampIsBeamTheory) {
  ModelPtr model = make_model("bracket", nullptr);
  const double L = 60, H = 45, t = 5, width = 30, force = 200;
  const double x[4] = {L, H, t, 90};
  // At 90 degrees the tip's centre line point is (L + R, R + H), R = 1.5 t; F = (-200, 0) N.
  const double R = 1.5 * t, moment = (R + H) * force, inertia = width * t * t * t / 12;
  const double axial = -force / (t * width);
  double outer = 0, inner = 0;
  const double p_outer[3] = {0, -t / 2, 15}, p_inner[3] = {0, t / 2, 15};
  ASSERT_EQ(analytic_model_field_at(model.get(), 1, x, p_outer, &outer), CADINTERP_OK);
  ASSERT_EQ(analytic_model_field_at(model.get(), 1, x, p_inner, &inner), CADINTERP_OK);
  EXPECT_NEAR(outer, std::fabs(axial + moment * (t / 2) / inertia), 1e-9 * outer);
  EXPECT_NEAR(inner, std::fabs(axial - moment * (t / 2) / inertia), 1e-9 * inner);
  // On the neutral axis only shear remains: the flange carries F along its axis, so none.
  double neutral = 0;
  const double p_neutral[3] = {0, 0, 15};
  ASSERT_EQ(analytic_model_field_at(model.get(), 1, x, p_neutral, &neutral), CADINTERP_OK);
  EXPECT_NEAR(neutral, std::fabs(axial), 1e-9);
}

TEST(AnalyticPlate, ResolutionFollowsSizeAndIdsDoNot) {
  const double x[3] = {70, 40, 6};
  std::vector<std::vector<int64_t>> reference;
  std::set<std::size_t> counts;
  for (const char* options : {"edge=3", "edge=5", "edge=8.5", "edge=20"}) {
    ModelPtr model = make_model("plate", options);
    Mesh mesh;
    References refs;
    ASSERT_EQ(analytic_model_mesh(model.get(), x, &mesh.m, nullptr), CADINTERP_OK);
    check_mesh(mesh, all_tags("plate"), options);
    counts.insert(mesh.m.vertex_count);
    ASSERT_EQ(analytic_model_references(model.get(), x, &refs.r, nullptr), CADINTERP_OK);
    std::vector<std::vector<int64_t>> ids;
    check_references(mesh, refs, 2, options, &ids);
    if (reference.empty())
      reference = ids;
    else
      EXPECT_EQ(ids, reference) << options;
    // The same control point is at the same place whatever the mesh.
    for (std::size_t p = 0; p < refs.r.point_count; ++p) {
      const double* q = &refs.r.point_positions[3 * p];
      for (int c = 0; c < 3; ++c) EXPECT_GE(q[c], 0.0);
      EXPECT_LE(q[0], x[0]);
      EXPECT_LE(q[1], x[1]);
      EXPECT_LE(q[2], x[2]);
    }
    check_fields(model.get(), x, mesh, options);
  }
  EXPECT_EQ(counts.size(), 4u);
  // edge=5 at 70 x 40 x 6 mm: 14 x 8 x 1 cells
  ModelPtr model = make_model("plate", nullptr);
  Mesh mesh;
  ASSERT_EQ(analytic_model_mesh(model.get(), x, &mesh.m, nullptr), CADINTERP_OK);
  EXPECT_EQ(mesh.m.vertex_count, 15u * 9u * 2u);
}

// The foldplate's B-rep topology changes at fold = 0: a crease edge (id 13) and a 7th face
// appear; the crease's end vertices (ids 5 and 8) change IDs, every other ID stays.
TEST(AnalyticFoldplate, TopologyChangesAtZeroFoldAndOnlyChangedEntitiesChangeIds) {
  ModelPtr model = make_model("foldplate", "edge=6");
  const double flat_x[4] = {70, 40, 6, -0.3}, fold_x[4] = {70, 40, 6, 0.5};
  Mesh flat, fold;
  ASSERT_EQ(analytic_model_mesh(model.get(), flat_x, &flat.m, nullptr), CADINTERP_OK);
  ASSERT_EQ(analytic_model_mesh(model.get(), fold_x, &fold.m, nullptr), CADINTERP_OK);
  check_mesh(flat, all_tags("plate"), "flat");
  std::set<int32_t> seven = all_tags("plate");
  seven.insert(7);
  check_mesh(fold, seven, "folded");
  // The rising half lies where x / length >= y / width, and rises to fold * thickness.
  double top = 0;
  for (std::size_t f = 0; f < fold.m.triangle_count; ++f) {
    if (fold.m.triangle_tags[f] != 7) continue;
    for (int k = 0; k < 3; ++k) {
      const double* p = fold.v(fold.m.triangles[3 * f + std::size_t(k)]);
      EXPECT_GE(p[0] / 70.0, p[1] / 40.0 - 1e-12);
      top = std::max(top, p[2]);
    }
  }
  EXPECT_DOUBLE_EQ(top, 6.0 + 0.5 * 6.0);

  References a, b;
  ASSERT_EQ(analytic_model_references(model.get(), flat_x, &a.r, nullptr), CADINTERP_OK);
  ASSERT_EQ(analytic_model_references(model.get(), fold_x, &b.r, nullptr), CADINTERP_OK);
  std::set<std::vector<int64_t>> ia, ib;
  for (std::size_t p = 0; p < a.r.point_count; ++p) ia.insert(a.id(p));
  for (std::size_t p = 0; p < b.r.point_count; ++p) ib.insert(b.id(p));
  std::vector<std::vector<int64_t>> only_flat, only_fold;
  std::set_difference(ia.begin(), ia.end(), ib.begin(), ib.end(), std::back_inserter(only_flat));
  std::set_difference(ib.begin(), ib.end(), ia.begin(), ia.end(), std::back_inserter(only_fold));
  ASSERT_EQ(only_flat.size(), 2u);
  EXPECT_EQ(only_flat[0][1], 5);
  EXPECT_EQ(only_flat[1][1], 8);
  ASSERT_EQ(only_fold.size(), 5u);  // the two vertices, with edge 13, and the crease's 3 samples
  for (const auto& id : only_fold) {
    if (id[0] == 0) {
      EXPECT_EQ(id.size(), 6u);
      EXPECT_EQ(id.back(), 13);
    } else {
      EXPECT_EQ(id[1], 13);
      EXPECT_EQ(id[2], 5);
      EXPECT_EQ(id[3], 8);
    }
  }
  // The crease's points lie on mesh vertices or edges along the diagonal x / length = y / width.
  for (std::size_t p = 0; p < b.r.point_count; ++p) {
    const std::vector<int64_t> id = b.id(p);
    if (id[0] != 1 || id[1] != 13) continue;
    const double* q = &b.r.point_positions[3 * p];
    EXPECT_NEAR(q[0] / 70.0, q[1] / 40.0, 1e-12);
    EXPECT_NEAR(q[2], 6.0, 1e-12);
  }
  EXPECT_EQ(b.r.path_count, a.r.path_count + 4);
}

TEST(AnalyticPlate, EdgeSamplesAreDyadicPoints) {
  ModelPtr model = make_model("plate", "edge=7");
  const double x[3] = {100, 20, 2};
  References refs;
  ASSERT_EQ(analytic_model_references(model.get(), x, &refs.r, nullptr), CADINTERP_OK);
  // Edge 1 runs along x from vertex 1 (origin) to vertex 2 (x = length): samples at 1/4, 1/2,
  // 3/4 of the length, named by their dyadic range.
  std::map<std::vector<int64_t>, double> want = {
      {{1, 1, 1, 2, -1, 0}, 25.0}, {{1, 1, 1, 2, -1}, 50.0}, {{1, 1, 1, 2, -1, 1}, 75.0}};
  int found = 0;
  for (std::size_t p = 0; p < refs.r.point_count; ++p) {
    auto it = want.find(refs.id(p));
    if (it == want.end()) continue;
    ++found;
    EXPECT_NEAR(refs.r.point_positions[3 * p], it->second, 1e-12);
    EXPECT_EQ(refs.r.point_positions[3 * p + 1], 0.0);
    EXPECT_EQ(refs.r.point_positions[3 * p + 2], 0.0);
  }
  EXPECT_EQ(found, 3);
}

TEST(AnalyticPlate, FieldsAreBeamTheory) {
  ModelPtr model = make_model("plate", nullptr);
  const double L = 80, W = 30, T = 4, x[3] = {L, W, T};
  const double inertia = W * T * T * T / 12, load = 50, young = 210000;
  double u[3];
  const double tip[3] = {L, 10, T / 2};
  ASSERT_EQ(analytic_model_field_at(model.get(), 2, x, tip, u), CADINTERP_OK);
  EXPECT_NEAR(u[2], -load * L * L * L / (3 * young * inertia), 1e-12);
  EXPECT_EQ(u[0], 0.0);  // the neutral plane does not stretch
  double vm = 0;
  const double root_top[3] = {0, 10, T};
  ASSERT_EQ(analytic_model_field_at(model.get(), 1, x, root_top, &vm), CADINTERP_OK);
  EXPECT_NEAR(vm, load * L * (T / 2) / inertia, 1e-9);
}

TEST(AnalyticHost, CurvedFailRegionCovers16PercentOfTheBox) {
  ModelPtr failing = make_model("plate", "fail_region=2");
  const int k = analytic_model_parameter_count(failing.get());
  const cadinterp_parameter_desc* p = analytic_model_parameters(failing.get());
  std::vector<double> x(static_cast<std::size_t>(k));
  const int n = 200;
  int inside = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      x[0] = p[0].lower + (i + 0.5) / n * (p[0].upper - p[0].lower);
      x[1] = p[1].lower + (j + 0.5) / n * (p[1].upper - p[1].lower);
      for (int d = 2; d < k; ++d) x[static_cast<std::size_t>(d)] = p[d].lower;
      inside += analytic_model_in_fail_region(failing.get(), x.data());
    }
  EXPECT_NEAR(inside / double(n * n), 0.16, 0.002);
  const char* message = nullptr;
  Mesh mesh;
  x[0] = p[0].upper;
  x[1] = p[1].upper;
  EXPECT_EQ(analytic_model_mesh(failing.get(), x.data(), &mesh.m, &message),
            CADINTERP_E_INFEASIBLE);
  ASSERT_NE(message, nullptr);
  EXPECT_NE(std::string(message).find("fail_region=2"), std::string::npos);
}

TEST(AnalyticHost, FailRegionAndDomain) {
  for (const char* name : {"bracket", "plate"}) {
    SCOPED_TRACE(name);
    ModelPtr failing = make_model(name, "fail_region=1");
    ModelPtr plain = make_model(name, nullptr);
    const int k = analytic_model_parameter_count(failing.get());
    const cadinterp_parameter_desc* p = analytic_model_parameters(failing.get());
    std::vector<double> corner(static_cast<std::size_t>(k)), centre(corner);
    for (int i = 0; i < k; ++i) {
      const auto u = static_cast<std::size_t>(i);
      centre[u] = 0.5 * (p[i].lower + p[i].upper);
      corner[u] = i < 2 ? p[i].upper - 0.1 * (p[i].upper - p[i].lower) : centre[u];
    }
    Mesh mesh;
    References refs;
    const char* message = nullptr;
    EXPECT_TRUE(analytic_model_in_fail_region(failing.get(), corner.data()));
    EXPECT_FALSE(analytic_model_in_fail_region(plain.get(), corner.data()));
    EXPECT_EQ(analytic_model_mesh(failing.get(), corner.data(), &mesh.m, &message),
              CADINTERP_E_INFEASIBLE);
    ASSERT_NE(message, nullptr);
    EXPECT_NE(std::string(message).find("fail_region"), std::string::npos);
    EXPECT_EQ(mesh.m.vertices, nullptr) << "output touched on failure";
    EXPECT_EQ(analytic_model_references(failing.get(), corner.data(), &refs.r, &message),
              CADINTERP_E_INFEASIBLE);
    // One corner only: each parameter alone in its top quarter is fine.
    std::vector<double> edge = centre;
    edge[0] = corner[0];
    EXPECT_EQ(analytic_model_mesh(failing.get(), edge.data(), &mesh.m, &message), CADINTERP_OK);
    analytic_mesh_free(&mesh.m);
    EXPECT_EQ(analytic_model_mesh(failing.get(), centre.data(), &mesh.m, &message), CADINTERP_OK);
    analytic_mesh_free(&mesh.m);
    EXPECT_EQ(analytic_model_mesh(plain.get(), corner.data(), &mesh.m, &message), CADINTERP_OK);
    // The truth exists in the fail region too.
    double value[3];
    const double origin[3] = {0, 0, 0};
    EXPECT_EQ(analytic_model_field_at(failing.get(), 0, corner.data(), origin, value),
              CADINTERP_OK);

    std::vector<double> outside = centre;
    outside[0] = p[0].upper + 1.0;
    Mesh none;
    EXPECT_EQ(analytic_model_mesh(plain.get(), outside.data(), &none.m, &message),
              CADINTERP_E_OUTSIDE_DOMAIN);
    outside[0] = std::nan("");
    EXPECT_EQ(analytic_model_mesh(plain.get(), outside.data(), &none.m, &message),
              CADINTERP_E_OUTSIDE_DOMAIN);
    EXPECT_EQ(analytic_model_field_at(plain.get(), 0, outside.data(), origin, value),
              CADINTERP_E_OUTSIDE_DOMAIN);
    EXPECT_EQ(analytic_model_field_at(plain.get(), 99, centre.data(), origin, value),
              CADINTERP_E_INVALID_ARGUMENT);
  }
}

TEST(AnalyticHost, Options) {
  struct Bad {
    const char* model;
    const char* options;
  };
  for (const Bad& bad : std::vector<Bad>{{"wrench", nullptr},
                                         {"Bracket", ""},
                                         {"bracket", "cells"},
                                         {"bracket", "cells=0"},
                                         {"bracket", "cells=65"},
                                         {"bracket", "cells=4x"},
                                         {"bracket", "edge=5"},
                                         {"bracket", "cells=4,cells=5"},
                                         {"bracket", "cells=4,"},
                                         {"bracket", "=4"},
                                         {"plate", "cells=4"},
                                         {"plate", "edge=0.4"},
                                         {"plate", "edge=1.2345"},
                                         {"plate", "edge=-5"},
                                         {"plate", "edge=5."},
                                         {"plate", "levels=7"},
                                         {"plate", "fail_region=3"},
                                         {"plate", "colour=red"}}) {
    const char* error = nullptr;
    analytic_model* m = analytic_model_create(bad.model, bad.options, &error);
    EXPECT_EQ(m, nullptr) << bad.model << " " << (bad.options ? bad.options : "(null)");
    analytic_model_destroy(m);
    ASSERT_NE(error, nullptr);
    EXPECT_EQ(std::string(error).rfind("analytic host: ", 0), 0u) << error;
  }
  EXPECT_EQ(std::string(analytic_model_identity(make_model(nullptr, nullptr).get())),
            "analytic bracket v1 (cells=4, levels=2, fail_region=0)");
  EXPECT_EQ(
      std::string(analytic_model_identity(make_model("plate", "fail_region=1,edge=2.5").get())),
      "analytic plate v1 (edge=2500 um, levels=2, fail_region=1)");
  EXPECT_EQ(std::string(analytic_model_name(make_model("", "levels=0").get())), "bracket");

  const double x[4] = {60, 45, 5, 90};
  Mesh small, large;
  ASSERT_EQ(analytic_model_mesh(make_model("bracket", "cells=2").get(), x, &small.m, nullptr),
            CADINTERP_OK);
  ASSERT_EQ(analytic_model_mesh(make_model("bracket", "cells=8").get(), x, &large.m, nullptr),
            CADINTERP_OK);
  EXPECT_LT(small.m.vertex_count, large.m.vertex_count);
  check_mesh(large, all_tags("bracket"), "bracket cells=8");
  EXPECT_NEAR(bbox_diagonal(small), bbox_diagonal(large), 1e-9) << "same shape, finer mesh";

  References none;
  ASSERT_EQ(analytic_model_references(make_model("bracket", "levels=0").get(), x, &none.r, nullptr),
            CADINTERP_OK);
  EXPECT_EQ(none.r.point_count, 16u);
  EXPECT_EQ(none.r.path_count, 24u);
}

TEST(AnalyticHost, RegionsNameTaggedFaces) {
  for (const char* name : {"bracket", "plate"}) {
    ModelPtr model = make_model(name, nullptr);
    ASSERT_EQ(analytic_model_region_count(model.get()), 2);
    const analytic_region* fixed = analytic_model_region(model.get(), 0);
    const analytic_region* load = analytic_model_region(model.get(), 1);
    EXPECT_STREQ(fixed->name, "fixed");
    EXPECT_STREQ(fixed->kind, "fixed");
    EXPECT_STREQ(load->name, "load");
    EXPECT_STREQ(load->kind, "force");
    EXPECT_EQ(analytic_model_region(model.get(), 2), nullptr);
    // The fixed face is where the stress is largest (the root of the cantilever), the load
    // face the far end: check through the mesh's tags that they are the two ends.
    const int k = analytic_model_parameter_count(model.get());
    std::vector<double> x(static_cast<std::size_t>(k));
    for (int i = 0; i < k; ++i)
      x[static_cast<std::size_t>(i)] = 0.5 * (analytic_model_parameters(model.get())[i].lower +
                                              analytic_model_parameters(model.get())[i].upper);
    Mesh mesh;
    ASSERT_EQ(analytic_model_mesh(model.get(), x.data(), &mesh.m, nullptr), CADINTERP_OK);
    for (std::size_t f = 0; f < mesh.m.triangle_count; ++f) {
      if (mesh.m.triangle_tags[f] != fixed->face_tags[0]) continue;
      for (int c = 0; c < 3; ++c) EXPECT_EQ(mesh.v(mesh.m.triangles[3 * f + c])[0], 0.0) << name;
    }
  }
}

TEST(AnalyticHost, DeterministicAndThreadSafe) {
  ModelPtr model = make_model("plate", "edge=3");
  const std::vector<std::vector<double>> xs = parameter_points(model.get(), 8);
  std::vector<std::vector<double>> serial(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) {
    Mesh mesh;
    ASSERT_EQ(analytic_model_mesh(model.get(), xs[i].data(), &mesh.m, nullptr), CADINTERP_OK);
    serial[i].assign(mesh.m.vertices, mesh.m.vertices + 3 * mesh.m.vertex_count);
  }
  std::vector<int> mismatches(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (std::size_t i = static_cast<std::size_t>(t); i < xs.size(); i += 2) {
        Mesh mesh;
        References refs;
        if (analytic_model_mesh(model.get(), xs[i].data(), &mesh.m, nullptr) != CADINTERP_OK ||
            analytic_model_references(model.get(), xs[i].data(), &refs.r, nullptr) !=
                CADINTERP_OK ||
            std::vector<double>(mesh.m.vertices, mesh.m.vertices + 3 * mesh.m.vertex_count) !=
                serial[i])
          ++mismatches[static_cast<std::size_t>(t)];
      }
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(mismatches, std::vector<int>(4, 0));
}

}  // namespace
