// Fixtures shared by the mapper's tests (mapping_tests): samples drawn from the analytic example
// host, and two solids tet-meshed here whose truth is their own construction. Test-only; each
// call builds a fresh sample, so tests may use them from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "analytic_host.h"
#include "mapping/mapping_quality.h"
#include "mesh/host_call.h"
#include "mesh/sample.h"

namespace cadinterp::mapping_test {

/// One model of the analytic host (`plate`, `foldplate`, `bracket`) with its options: samples
/// at a parameter point, and the closed-form fields there as the transfer's truth. Throws on an
/// unknown model or an infeasible point (a broken fixture, not a mapper failure).
struct Model {
  const cadinterp_host* host = nullptr;
  const analytic_model* model = nullptr;
  explicit Model(const char* name, const char* options) {
    const char* err = nullptr;
    host = cadinterp_host_entry(name, options, &err);
    if (!host) throw std::runtime_error(err ? err : "no host");
    model = analytic_host_model(host);
  }
  mesh::Sample at(const std::vector<double>& x) const {
    mesh::Sample s = mesh::Host(*host).evaluate(x.data());
    if (!s.feasible) throw std::runtime_error("infeasible: " + s.message);
    return s;
  }
  mapping::FieldTruth truth(const std::vector<double>& x) const {
    return [this, x](int f, const double* p, double* v) {
      return analytic_model_field_at(model, f, x.data(), p, v) == CADINTERP_OK;
    };
  }
};

// A thick-walled tube, tet-meshed here: the analytic stand-in for a B-rep cylinder face with a
// seam (what the OpenCASCADE host emits: its lateral faces bounded by two closed circle edges
// and crossed by a seam edge whose paths have the same face on both sides). Control points and
// paths follow cadinterp_builder.h's ID scheme with one subdivision level.
namespace tube {

constexpr double kPi = 3.14159265358979323846;

struct Shape {
  double r_in, r_out, height;
  int n, k;  // angular and axial segments (multiples of 4: the edge points are mesh vertices)
};

/// Tags: 1 outer wall, 2 inner wall, 3 top, 4 bottom.
mesh::Sample make(const Shape& t);

}  // namespace tube

namespace voxel {

// A plate [0, X] x [0, Y] x [0, Z] on a grid of step h, with square through-holes (cells
// removed), each hex split into the 6 Kuhn tets around its main diagonal (conforming across
// cells). Tags: top 1, bottom 2, the four outer walls 3..6, the walls of hole k one tag 10 + k
// (an annulus). Control points: the plate's 8 corners, and one corner of each hole at the top
// and at the bottom (a hole loop with a single anchor: the two-path split cannot cut it).
struct Hole {
  double x0, y0, x1, y1;
};

mesh::Sample plate(double X, double Y, double Z, double h, const std::vector<Hole>& holes);

// Calls f(tag, x) for each corner of each canonical boundary triangle with its mapped position
// (a vertex once per triangle it is a corner of): the checks that a face keeps its geometry.
template <class F>
void for_each_tagged_corner(const mesh::Sample& canonical, const mesh::MappedSample& m, F f) {
  for (std::size_t t = 0; t < canonical.triangle_count(); ++t)
    for (int c = 0; c < 3; ++c)
      f(canonical.triangle_tags[t],
        &m.vertices[3 * std::size_t(canonical.triangles[3 * t + std::size_t(c)])]);
}

// Each mapped boundary vertex of the outer faces on its own face's plane (the faces keep their
// tags through the combinatorics): top z = Z, bottom z = 0, walls x = 0 and x = X.
void expect_on_outer_planes(const mesh::Sample& canonical, const mesh::MappedSample& m, double X,
                            double Z);

}  // namespace voxel

}  // namespace cadinterp::mapping_test
