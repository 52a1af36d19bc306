/* "bracket": a bent sheet-metal bracket whose mesh combinatorics never change.
 *
 * A strip of sheet (thickness t, width 30 mm) runs along +x as a flange of length L, bends
 * counter-clockwise about z by the angle theta with inner radius t (a usual press-brake rule),
 * and continues straight as a leg of length H. The sheet's mid-surface is the curve c(s), s its
 * arc length; a point of the solid is c(s) + d N(s) + z e_z with d in [-t/2, t/2] (N the left
 * normal, towards the bend's centre) and z in [0, width]. The grid's axes are (s, d, z), so the
 * cell counts are fixed and positions depend on x through cos and sin of theta and products of
 * lengths: smooth and nonlinear.
 *
 * B-rep (README.md): 16 vertices on 4 stations along s (the two ends and the two tangent lines
 * of the bend) x 2 sides of the sheet x 2 edges of the strip; 24 edges; 10 faces.
 *
 * Fields: the bracket is clamped at the flange's end face and pulled at the leg's end face by a
 * force F = (-200, 0, 0) N. von_mises is beam theory on the strip's cross-section at s (axial
 * force, bending moment and shear of F carried back along the centre line; the curved-beam
 * correction in the bend is left out), evaluated at each tet's centroid. temperature is a hot
 * spot at the leg's end face, a Gaussian in the position.
 */
#include <math.h>

#include "analytic_internal.h"

#define BRACKET_WIDTH 30.0
#define BRACKET_FORCE_X (-200.0)
#define BRACKET_FORCE_Y 0.0
#define BRACKET_PI 3.14159265358979323846

const cadinterp_parameter_desc analytic_bracket_parameters[4] = {
    {"length", "mm", 40.0, 80.0},
    {"height", "mm", 30.0, 60.0},
    {"thickness", "mm", 3.0, 8.0},
    {"bend_angle", "deg", 45.0, 135.0}};

const analytic_field_desc analytic_bracket_fields[2] = {
    {"temperature", "degC", CADINTERP_PER_VERTEX, 1}, {"von_mises", "MPa", CADINTERP_PER_TET, 1}};

static const int32_t kFixedTags[1] = {1};
static const int32_t kLoadTags[1] = {2};
const analytic_region analytic_bracket_regions[2] = {{"fixed", "fixed", kFixedTags, 1},
                                                     {"load", "force", kLoadTags, 1}};

/* Vertex list index of the B-rep vertex at station `st` (0..3), sheet side `jb` (0: outer,
 * d = -t/2; 1: inner) and strip edge `kb` (0: z = 0; 1: z = width); its id is this + 1. */
static int vertex_at(int st, int jb, int kb) { return 4 * st + jb + 2 * kb; }

static void add_edge(analytic_brep* b, int64_t id, int u, int v) {
  analytic_brep_edge* e = &b->edges[b->edge_count++];
  e->id = id;
  e->ends[0] = u;
  e->ends[1] = v;
}

double analytic_bracket_volume(const double* x) {
  /* width * thickness * (flange + leg + bend), the bend an annular sector whose area is
   * angle * (mid-surface radius 1.5 t) * t (Pappus). */
  const double t = x[2], angle = x[3] * (BRACKET_PI / 180.0);
  return BRACKET_WIDTH * t * (x[0] + x[1] + 1.5 * t * angle);
}

void analytic_bracket_shape(const analytic_model* m, const double* x, analytic_shape* s) {
  analytic_bracket_geom* g = &s->geom.bracket;
  analytic_brep* b = &s->brep;
  const int n = m->cells;
  int stations[4], st, jb, kb, seg;

  g->length = x[0];
  g->height = x[1];
  g->thickness = x[2];
  g->angle = x[3] * (BRACKET_PI / 180.0);
  g->radius = 1.5 * x[2]; /* inner radius t, so the mid-surface's is t + t/2 */
  g->width = BRACKET_WIDTH;
  /* Cells of about equal length along the strip at mid-range sizes; the bend gets fewer since
   * its arc is short, the thickness fewer still. */
  g->sections[0] = 2 * n;
  g->sections[1] = n;
  g->sections[2] = 2 * n;
  s->n[0] = 5 * n;
  s->n[1] = n / 2 > 0 ? n / 2 : 1;
  s->n[2] = n;

  stations[0] = 0;
  stations[1] = g->sections[0];
  stations[2] = g->sections[0] + g->sections[1];
  stations[3] = s->n[0];
  b->vertex_count = 16;
  for (st = 0; st < 4; ++st)
    for (kb = 0; kb < 2; ++kb)
      for (jb = 0; jb < 2; ++jb) {
        analytic_brep_vertex* v = &b->vertices[vertex_at(st, jb, kb)];
        v->id = vertex_at(st, jb, kb) + 1;
        v->index[0] = stations[st];
        v->index[1] = jb * s->n[1];
        v->index[2] = kb * s->n[2];
      }
  b->edge_count = 0;
  /* Across the width at every station: end-face edges at the ends, tangent lines in between. */
  for (st = 0; st < 4; ++st)
    for (jb = 0; jb < 2; ++jb)
      add_edge(b, 1 + 2 * st + jb, vertex_at(st, jb, 0), vertex_at(st, jb, 1));
  /* Through the thickness at the two ends only: the sides are single planar faces. */
  for (st = 0; st < 4; st += 3)
    for (kb = 0; kb < 2; ++kb)
      add_edge(b, 9 + (st == 3 ? 2 : 0) + kb, vertex_at(st, 0, kb), vertex_at(st, 1, kb));
  /* Along the strip: line, arc, line on each of the four long corners. */
  for (seg = 0; seg < 3; ++seg)
    for (kb = 0; kb < 2; ++kb)
      for (jb = 0; jb < 2; ++jb)
        add_edge(b, 13 + 4 * seg + jb + 2 * kb, vertex_at(seg, jb, kb), vertex_at(seg + 1, jb, kb));
}

/* Mid-surface point c and unit tangent T at arc length s (clamped to the strip). */
static void centre_line(const analytic_bracket_geom* g, double s, double c[2], double t[2]) {
  const double bend_end = g->length + g->radius * g->angle;
  if (s <= g->length) {
    c[0] = s > 0.0 ? s : 0.0;
    c[1] = 0.0;
    t[0] = 1.0;
    t[1] = 0.0;
  } else if (s <= bend_end) {
    const double phi = (s - g->length) / g->radius;
    c[0] = g->length + g->radius * sin(phi);
    c[1] = g->radius - g->radius * cos(phi);
    t[0] = cos(phi);
    t[1] = sin(phi);
  } else {
    const double u = s - bend_end < g->height ? s - bend_end : g->height;
    t[0] = cos(g->angle);
    t[1] = sin(g->angle);
    c[0] = g->length + g->radius * sin(g->angle) + u * t[0];
    c[1] = g->radius - g->radius * cos(g->angle) + u * t[1];
  }
}

void analytic_bracket_position(const analytic_shape* s, const int ijk[3], double p[3]) {
  const analytic_bracket_geom* g = &s->geom.bracket;
  const int* n = g->sections;
  const int i = ijk[0];
  double arc, c[2], t[2], d;
  /* Arc length at the grid station, uniform within each section. */
  if (i <= n[0])
    arc = g->length * i / n[0];
  else if (i <= n[0] + n[1])
    arc = g->length + g->radius * g->angle * (i - n[0]) / n[1];
  else
    arc = g->length + g->radius * g->angle + g->height * (i - n[0] - n[1]) / n[2];
  centre_line(g, arc, c, t);
  d = g->thickness * ((double)ijk[1] / s->n[1] - 0.5);
  p[0] = c[0] - d * t[1];
  p[1] = c[1] + d * t[0];
  p[2] = g->width * ijk[2] / s->n[2];
}

int32_t analytic_bracket_face_tag(const analytic_shape* s, int axis, int side, const int cell[3]) {
  const int* n = s->geom.bracket.sections;
  if (axis == 0) return side ? 2 : 1;
  if (axis == 2) return side ? 10 : 9;
  /* outer (d = -t/2) faces 3..5, inner 6..8: flange, bend, leg */
  return (side ? 6 : 3) + (cell[0] < n[0] ? 0 : (cell[0] < n[0] + n[1] ? 1 : 2));
}

static double clamp(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* Arc length s and offset d of the sheet point nearest p: the piece (flange, bend, leg) whose
 * own coordinates reproduce p best, where leaving the piece's range of s or of d costs the
 * distance left over. A point of the solid is reproduced exactly by its own piece. */
static void locate(const analytic_bracket_geom* g, const double p[3], double* s, double* d) {
  const double half = 0.5 * g->thickness, L = g->length, R = g->radius, th = g->angle;
  double best, err;
  {
    const double u = clamp(p[0], 0.0, L);
    best = fabs(p[0] - u) + fmax(0.0, fabs(p[1]) - half);
    *s = u;
    *d = p[1];
  }
  {
    const double rx = p[0] - L, ry = p[1] - R, rho = hypot(rx, ry);
    const double phi = clamp(atan2(rx, -ry), 0.0, th);
    err = hypot(rx - rho * sin(phi), ry + rho * cos(phi)) + fmax(0.0, fabs(R - rho) - half);
    if (err < best) {
      best = err;
      *s = L + R * phi;
      *d = R - rho;
    }
  }
  {
    const double qx = p[0] - (L + R * sin(th)), qy = p[1] - (R - R * cos(th));
    const double u = qx * cos(th) + qy * sin(th), v = -qx * sin(th) + qy * cos(th);
    const double uc = clamp(u, 0.0, g->height);
    err = fabs(u - uc) + fmax(0.0, fabs(v) - half);
    if (err < best) {
      *s = L + R * th + uc;
      *d = v;
    }
  }
}

void analytic_bracket_field_at(const analytic_shape* s, int field, const double p[3],
                               double* value) {
  const analytic_bracket_geom* g = &s->geom.bracket;
  const double total = g->length + g->radius * g->angle + g->height;
  double tip[2], tip_t[2];
  centre_line(g, total, tip, tip_t);
  if (field == 0) {
    /* Hot spot at the centre of the load face, spread over a third of the strip's length. */
    const double spread = 0.35 * (g->length + g->height);
    const double dx = p[0] - tip[0], dy = p[1] - tip[1], dz = p[2] - 0.5 * g->width;
    *value = 20.0 + 60.0 * exp(-(dx * dx + dy * dy + dz * dz) / (2.0 * spread * spread));
  } else {
    double arc, d, c[2], t[2];
    const double t3 = g->thickness * g->thickness * g->thickness;
    const double area = g->thickness * g->width, inertia = g->width * t3 / 12.0;
    double axial, shear, moment, sigma, tau, ratio;
    locate(g, p, &arc, &d);
    d = clamp(d, -0.5 * g->thickness, 0.5 * g->thickness);
    centre_line(g, arc, c, t);
    axial = BRACKET_FORCE_X * t[0] + BRACKET_FORCE_Y * t[1];
    shear = -BRACKET_FORCE_X * t[1] + BRACKET_FORCE_Y * t[0];
    /* moment about the section's centre of F acting at the tip (N mm) */
    moment = (tip[0] - c[0]) * BRACKET_FORCE_Y - (tip[1] - c[1]) * BRACKET_FORCE_X;
    sigma = axial / area - moment * d / inertia;
    ratio = 2.0 * d / g->thickness;
    tau = 1.5 * shear / area * (1.0 - ratio * ratio);
    *value = sqrt(sigma * sigma + 3.0 * tau * tau);
  }
}
