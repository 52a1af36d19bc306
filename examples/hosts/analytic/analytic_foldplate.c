/* "foldplate": the plate of analytic_plate.c whose top face folds along its diagonal when
 * fold > 0, so that its B-rep topology changes inside the parameter box (paper §6: pairs across
 * topology changes). At fold <= 0 it is the plate (8 vertices, 12 edges, 6 faces); at fold > 0
 * the corner (length, 0) of the top face rises by fold * thickness, and the top face splits
 * along the crease from (0, 0, thickness) to (length, width, thickness) into two planar
 * triangles: a 13th edge (id 13) and a 7th face (tag 7, the rising half). Unchanged entities
 * keep their IDs; the crease's two end vertices change theirs (their adjacent edges change), as
 * the ID scheme of cadinterp_builder.h says they must. The side faces stay planar.
 *
 * The crease follows mesh edges because the grid has as many cells along the length as along
 * the width, round(max(length, width) / edge), and the boundary quads are cut along the same
 * diagonal (analytic_mesh.c). Fields and regions are the plate's closed forms.
 */
#include <math.h>

#include "analytic_internal.h"

const cadinterp_parameter_desc analytic_foldplate_parameters[4] = {{"length", "mm", 40.0, 100.0},
                                                                   {"width", "mm", 20.0, 60.0},
                                                                   {"thickness", "mm", 2.0, 10.0},
                                                                   {"fold", "1", -1.0, 1.0}};

void analytic_foldplate_shape(const analytic_model* m, const double* x, analytic_shape* s) {
  const double edge = (double)m->edge_um / 1000.0;
  const long in_plane = lround((x[0] > x[1] ? x[0] : x[1]) / edge);
  const long across = lround(x[2] / edge);
  analytic_plate_shape(m, x, s); /* the plate's B-rep vertices and edges at its grid */
  s->n[0] = s->n[1] = in_plane > 1 ? (int)in_plane : 1;
  s->n[2] = across > 1 ? (int)across : 1;
  {
    int v, a;
    for (v = 0; v < 8; ++v)
      for (a = 0; a < 3; ++a) s->brep.vertices[v].index[a] = ((v >> a) & 1) * s->n[a];
  }
  s->geom.plate.rise = x[3] > 0 ? x[3] * x[2] : 0.0;
  if (s->geom.plate.rise > 0) {
    /* The crease: corner (0, 0, 1) (id 5) to corner (1, 1, 1) (id 8). */
    analytic_brep_edge* e = &s->brep.edges[s->brep.edge_count++];
    e->id = 13;
    e->ends[0] = 4;
    e->ends[1] = 7;
  }
}

void analytic_foldplate_position(const analytic_shape* s, const int ijk[3], double p[3]) {
  const analytic_plate_geom* g = &s->geom.plate;
  const double u = (double)ijk[0] / s->n[0], v = (double)ijk[1] / s->n[1];
  const double top = g->size[2] + g->rise * (u > v ? u - v : 0.0);
  p[0] = g->size[0] * u;
  p[1] = g->size[1] * v;
  p[2] = top * ijk[2] / s->n[2];
}

int32_t analytic_foldplate_triangle_tag(const analytic_shape* s, int axis, int side,
                                        const int cell[3], int half) {
  /* The top quad's axes are (b, c) = (x, y): half 0 (v00, v10, v11) lies where x >= y. */
  if (axis == 2 && side == 1 && s->geom.plate.rise > 0) {
    const int rising = cell[0] > cell[1] || (cell[0] == cell[1] && half == 0);
    return rising ? 7 : 6;
  }
  return analytic_plate_face_tag(s, axis, side, cell);
}
