/* "plate": a cantilever plate [0, length] x [0, width] x [0, thickness] whose mesh follows its
 * size: round(size / edge) cells per axis (at least one), so the vertex count changes across
 * the parameter box while the B-rep (8 vertices, 12 edges, 6 faces) never does. Samples of
 * different combinatorics are what the builder's mapping exists for (paper §6).
 *
 * Fields are closed forms of the position in the solid at x (never of grid indices), so that
 * values can be compared at any point whatever the mesh: Euler-Bernoulli beam theory for a
 * steel plate clamped at x = 0 and loaded by P = 50 N downwards (-z) on the face x = length,
 * and a temperature rising towards the loaded end.
 */
#include <math.h>

#include "analytic_internal.h"

#define PLATE_LOAD 50.0      /* N, along -z */
#define PLATE_YOUNG 210000.0 /* MPa (steel) */
#define PLATE_PI 3.14159265358979323846

const cadinterp_parameter_desc analytic_plate_parameters[3] = {
    {"length", "mm", 40.0, 100.0}, {"width", "mm", 20.0, 60.0}, {"thickness", "mm", 2.0, 10.0}};

const analytic_field_desc analytic_plate_fields[3] = {
    {"temperature", "degC", CADINTERP_PER_VERTEX, 1},
    {"von_mises", "MPa", CADINTERP_PER_TET, 1},
    {"displacement", "mm", CADINTERP_PER_VERTEX, 3}};

static const int32_t kFixedTags[1] = {1};
static const int32_t kLoadTags[1] = {2};
const analytic_region analytic_plate_regions[2] = {{"fixed", "fixed", kFixedTags, 1},
                                                   {"load", "force", kLoadTags, 1}};

void analytic_plate_shape(const analytic_model* m, const double* x, analytic_shape* s) {
  analytic_plate_geom* g = &s->geom.plate;
  analytic_brep* b = &s->brep;
  const double edge = (double)m->edge_um / 1000.0;
  int a, v;
  for (a = 0; a < 3; ++a) {
    const long cells = lround(x[a] / edge);
    g->size[a] = x[a];
    s->n[a] = cells > 1 ? (int)cells : 1;
  }
  /* Corner (bx, by, bz) in {0,1}^3 has id 1 + bx + 2 by + 4 bz. */
  b->vertex_count = 8;
  for (v = 0; v < 8; ++v) {
    b->vertices[v].id = v + 1;
    for (a = 0; a < 3; ++a) b->vertices[v].index[a] = ((v >> a) & 1) * s->n[a];
  }
  /* The edge along axis a whose other two corner bits (axes a+1, a+2 cyclically) are (u, w)
   * has id 1 + 4 a + u + 2 w. */
  b->edge_count = 12;
  for (a = 0; a < 3; ++a) {
    int u, w;
    for (w = 0; w < 2; ++w)
      for (u = 0; u < 2; ++u) {
        analytic_brep_edge* e = &b->edges[4 * a + u + 2 * w];
        const int corner = (u << ((a + 1) % 3)) | (w << ((a + 2) % 3));
        e->id = 1 + 4 * a + u + 2 * w;
        e->ends[0] = corner;
        e->ends[1] = corner | (1 << a);
      }
  }
}

void analytic_plate_position(const analytic_shape* s, const int ijk[3], double p[3]) {
  int a;
  for (a = 0; a < 3; ++a) p[a] = s->geom.plate.size[a] * ijk[a] / s->n[a];
}

int32_t analytic_plate_face_tag(const analytic_shape* s, int axis, int side, const int cell[3]) {
  (void)s;
  (void)cell;
  /* x = 0: 1 (fixed), x = length: 2 (load), y: 3 / 4, z: 5 (bottom) / 6 (top) */
  return 1 + 2 * axis + side;
}

void analytic_plate_field_at(const analytic_shape* s, int field, const double p[3], double* value) {
  const double length = s->geom.plate.size[0], width = s->geom.plate.size[1];
  const double thickness = s->geom.plate.size[2];
  const double inertia = width * thickness * thickness * thickness / 12.0;
  const double zeta = p[2] - 0.5 * thickness; /* height above the neutral plane */
  if (field == 0) {
    const double r = p[0] / length;
    *value =
        20.0 + 60.0 * r * r * (1.0 + 0.25 * cos(PLATE_PI * p[1] / width)) + 8.0 * p[2] / thickness;
  } else if (field == 1) {
    const double sigma = PLATE_LOAD * (length - p[0]) * zeta / inertia;
    const double ratio = 2.0 * zeta / thickness;
    const double tau = 1.5 * PLATE_LOAD / (width * thickness) * (1.0 - ratio * ratio);
    *value = sqrt(sigma * sigma + 3.0 * tau * tau);
  } else {
    /* deflection w(X) and slope w'(X) of the clamped beam; sections stay plane and normal */
    const double ei = PLATE_YOUNG * inertia, X = p[0];
    const double w = -PLATE_LOAD * X * X * (3.0 * length - X) / (6.0 * ei);
    const double slope = -PLATE_LOAD * X * (2.0 * length - X) / (2.0 * ei);
    value[0] = -zeta * slope;
    value[1] = 0.0;
    value[2] = w;
  }
}
