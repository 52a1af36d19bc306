/* Internals of the analytic host shared by its C files (not for tests or users).
 *
 * Both models are a structured grid of n[0] x n[1] x n[2] hexahedral cells mapped smoothly into
 * space, so one mesher (analytic_mesh.c) and one reference generator (analytic_brep.c) serve
 * them; a model supplies the grid size, the map of grid vertices to positions, the face tags of
 * boundary cell faces, and its B-rep vertices and edges as grid indices (analytic_bracket.c,
 * analytic_plate.c).
 */
#ifndef CADINTERP_ANALYTIC_INTERNAL_H
#define CADINTERP_ANALYTIC_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "analytic_host.h"

enum { ANALYTIC_BRACKET = 0, ANALYTIC_PLATE = 1, ANALYTIC_FOLDPLATE = 2 };

/* The option ranges (analytic_models.c) keep a grid below a million cells, so every index fits
 * uint32 and every size computation size_t. */
struct analytic_model {
  int kind;
  int cells;       /* bracket: mesh density */
  long edge_um;    /* plate, foldplate: target edge length in micrometres (integers keep
                     identity exact) */
  int levels;      /* edge subdivision levels of the control points */
  int fail_region; /* nonzero: infeasible corner of the box */
  char identity[160];
  /* Run-time behaviour, left out of the identity because results do not depend on it (a store
   * written with one setting resumes with another): */
  long sleep_ms;   /* sleep per regenerate, a stand-in for a slow CAD kernel and FEM */
  long kill_after; /* -1: off; else the process kills itself at its (kill_after+1)th regenerate */
  long regenerations; /* regenerate calls so far in this process (kill_after's count; atomic) */
};

/* One B-rep vertex: stable id and its grid vertex. */
typedef struct analytic_brep_vertex {
  int64_t id;
  int index[3];
} analytic_brep_vertex;

/* One straight B-rep edge along a grid axis (or a grid diagonal) between two vertices (indices into
 * the vertex list). Its parameter runs from the end with the smaller vertex id to the larger, so
 * that the hierarchical sample IDs mean the same point on every shape. */
typedef struct analytic_brep_edge {
  int64_t id;
  int ends[2];
} analytic_brep_edge;

#define ANALYTIC_MAX_BREP_VERTICES 16
#define ANALYTIC_MAX_BREP_EDGES 24

typedef struct analytic_brep {
  int vertex_count;
  analytic_brep_vertex vertices[ANALYTIC_MAX_BREP_VERTICES];
  int edge_count;
  analytic_brep_edge edges[ANALYTIC_MAX_BREP_EDGES];
} analytic_brep;

/* Bracket at x: see analytic_bracket.c. Lengths in mm, angle in radians. */
typedef struct analytic_bracket_geom {
  double length, height, thickness, angle;
  double radius; /* of the sheet's mid-surface in the bend */
  double width;
  int sections[3]; /* cells along flange, bend, leg */
} analytic_bracket_geom;

typedef struct analytic_plate_geom {
  double size[3]; /* length, width, thickness in mm */
  double rise;    /* foldplate: height of the top face's fold at corner (length, 0); 0: flat */
} analytic_plate_geom;

/* A model evaluated at x: what the mesher and the reference generator need. */
typedef struct analytic_shape {
  int kind;
  int n[3]; /* cells per grid axis */
  union {
    analytic_bracket_geom bracket;
    analytic_plate_geom plate;
  } geom;
  analytic_brep brep;
} analytic_shape;

/* Index of grid vertex (i, j, k) in the mesh's vertex array. */
static inline size_t analytic_grid_vertex(const int n[3], int i, int j, int k) {
  return (size_t)i + (size_t)(n[0] + 1) * ((size_t)j + (size_t)(n[1] + 1) * (size_t)k);
}

/* ---- analytic_models.c: dispatch on the model kind ---- */
void analytic_shape_position(const analytic_shape* s, const int ijk[3], double p[3]);
int32_t analytic_shape_face_tag(const analytic_shape* s, int axis, int side, const int cell[3]);
/* The tag of one of the two triangles of a boundary quad: half 0 is (v00, v10, v11), half 1
 * (v00, v11, v01) in the quad's (b, c) axes (analytic_mesh.c). The face tag unless a B-rep edge
 * runs along the quad's diagonal (the foldplate's crease). */
int32_t analytic_shape_triangle_tag(const analytic_shape* s, int axis, int side, const int cell[3],
                                    int half);

/* ---- analytic_mesh.c ---- */
/* Kuhn tets and boundary triangles of the shape's grid; out untouched on failure
 * (CADINTERP_E_OUT_OF_MEMORY). */
cadinterp_status analytic_shape_mesh(const analytic_shape* s, analytic_mesh* out);

/* ---- analytic_brep.c ---- */
/* Control points and paths of the shape's B-rep; `positions` are the mesh vertices of the shape
 * (grid order), so that every point and path lies on the meshed boundary. */
cadinterp_status analytic_shape_references(const analytic_shape* s, const double* positions,
                                           int levels, analytic_references* out);

/* ---- analytic_bracket.c ---- */
extern const cadinterp_parameter_desc analytic_bracket_parameters[4];
extern const analytic_field_desc analytic_bracket_fields[2];
extern const analytic_region analytic_bracket_regions[2];
void analytic_bracket_shape(const analytic_model* m, const double* x, analytic_shape* s);
/* The bracket's exact solid volume at x (the B-rep's, not the mesh's). */
double analytic_bracket_volume(const double* x);
void analytic_bracket_position(const analytic_shape* s, const int ijk[3], double p[3]);
int32_t analytic_bracket_face_tag(const analytic_shape* s, int axis, int side, const int cell[3]);
void analytic_bracket_field_at(const analytic_shape* s, int field, const double p[3],
                               double* value);

/* ---- analytic_plate.c ---- */
extern const cadinterp_parameter_desc analytic_plate_parameters[3];
extern const analytic_field_desc analytic_plate_fields[3];
extern const analytic_region analytic_plate_regions[2];
void analytic_plate_shape(const analytic_model* m, const double* x, analytic_shape* s);
void analytic_plate_position(const analytic_shape* s, const int ijk[3], double p[3]);
int32_t analytic_plate_face_tag(const analytic_shape* s, int axis, int side, const int cell[3]);
void analytic_plate_field_at(const analytic_shape* s, int field, const double p[3], double* value);

/* ---- analytic_foldplate.c (fields and regions: the plate's) ---- */
extern const cadinterp_parameter_desc analytic_foldplate_parameters[4];
void analytic_foldplate_shape(const analytic_model* m, const double* x, analytic_shape* s);
void analytic_foldplate_position(const analytic_shape* s, const int ijk[3], double p[3]);
int32_t analytic_foldplate_triangle_tag(const analytic_shape* s, int axis, int side,
                                        const int cell[3], int half);

#endif /* CADINTERP_ANALYTIC_INTERNAL_H */
