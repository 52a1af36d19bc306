/* Control points and paths of a model's B-rep (cadinterp_builder.h ID scheme, paper §6.2).
 *
 * Vertices: { 0, vertex id, sorted adjacent edge ids }. Edge samples: { 1, edge id, sorted end
 * vertex ids, -1, i_1 .. i_d } for depths d = 0 .. levels-1, i.e. the midpoints of the dyadic
 * ranges of the edge's parameter; depth 0 (no i's) is the edge's midpoint, so `levels` levels
 * give the 2^levels - 1 points j / 2^levels. The number of levels is fixed per model rather than
 * chosen from the edge's length, so that an edge has the same sample IDs wherever it exists.
 *
 * Points and paths are placed on the mesh, not on the exact curve: a bend's edge is an arc but
 * its mesh is a polyline of chords, and a control point off the mesh would leave the mapping to
 * guess which triangle it belongs to.
 */
#include <stdlib.h>
#include <string.h>

#include "analytic_internal.h"

/* Ends ordered by vertex id: the direction of the edge's parameter. */
static void edge_ends(const analytic_brep* b, const analytic_brep_edge* e, int* from, int* to) {
  const int u = e->ends[0], v = e->ends[1];
  const int swap = b->vertices[u].id > b->vertices[v].id;
  *from = swap ? v : u;
  *to = swap ? u : v;
}

/* Grid steps from vertex `from` to `to`: the unit step (each component -1, 0 or 1) and their
 * count. An edge runs along a grid axis, or along a diagonal of the grid (the same number of
 * steps on each axis it moves along; the foldplate's crease). */
static int edge_steps(const analytic_brep* b, int from, int to, int dir[3]) {
  int a, span = 0;
  for (a = 0; a < 3; ++a) {
    const int d = b->vertices[to].index[a] - b->vertices[from].index[a];
    dir[a] = (d > 0) - (d < 0);
    if (abs(d) > span) span = abs(d);
  }
  return span;
}

/* The point numer / denom grid steps along `dir` from grid vertex `base`, linear between the
 * two grid vertices around it: a point of the mesh edge. */
static void grid_point(const analytic_shape* s, const double* positions, const int base[3],
                       const int dir[3], long numer, long denom, double p[3]) {
  int q[3], c;
  const long i0 = numer / denom; /* numer >= 0 */
  const double frac = (double)(numer - i0 * denom) / (double)denom;
  const double* a;
  for (c = 0; c < 3; ++c) q[c] = base[c] + dir[c] * (int)i0;
  a = &positions[3 * analytic_grid_vertex(s->n, q[0], q[1], q[2])];
  if (frac == 0.0) {
    memcpy(p, a, 3 * sizeof(double));
    return;
  }
  for (c = 0; c < 3; ++c) q[c] += dir[c];
  {
    const double* b = &positions[3 * analytic_grid_vertex(s->n, q[0], q[1], q[2])];
    for (c = 0; c < 3; ++c) p[c] = (1.0 - frac) * a[c] + frac * b[c];
  }
}

static int compare_int64(const void* a, const void* b) {
  const int64_t x = *(const int64_t*)a, y = *(const int64_t*)b;
  return (x > y) - (x < y);
}

/* Adjacent edge ids of vertex v, sorted; returns their count. */
static int vertex_edges(const analytic_brep* b, int v, int64_t* ids) {
  int e, count = 0;
  for (e = 0; e < b->edge_count; ++e)
    if (b->edges[e].ends[0] == v || b->edges[e].ends[1] == v) ids[count++] = b->edges[e].id;
  qsort(ids, (size_t)count, sizeof(int64_t), compare_int64);
  return count;
}

cadinterp_status analytic_shape_references(const analytic_shape* s, const double* positions,
                                           int levels, analytic_references* out) {
  const analytic_brep* b = &s->brep;
  const long segments = 1L << levels; /* paths per edge; also the fractions' denominator */
  const size_t samples = (size_t)segments - 1;
  analytic_references r;
  size_t id_total = 0, path_rows = 0, point = 0, id_at = 0, path = 0, row = 0;
  int v, e, d;

  memset(&r, 0, sizeof(r));
  r.point_count = (size_t)b->vertex_count + (size_t)b->edge_count * samples;
  r.path_count = (size_t)b->edge_count * (size_t)segments;
  for (v = 0; v < b->vertex_count; ++v) {
    int64_t ids[ANALYTIC_MAX_BREP_EDGES];
    id_total += 2 + (size_t)vertex_edges(b, v, ids);
  }
  for (d = 0; d < levels; ++d)
    id_total += (size_t)b->edge_count * ((size_t)1 << d) * (5 + (size_t)d);
  for (e = 0; e < b->edge_count; ++e) {
    int dir[3];
    const int span = edge_steps(b, b->edges[e].ends[0], b->edges[e].ends[1], dir);
    /* two ends per path, plus the grid vertices strictly inside the edge, each inside one path */
    path_rows += 2 * (size_t)segments + (size_t)(span - 1);
  }

  r.point_id_offsets = (size_t*)malloc((r.point_count + 1) * sizeof(size_t));
  r.point_ids = (int64_t*)malloc(id_total * sizeof(int64_t));
  r.point_positions = (double*)malloc(3 * r.point_count * sizeof(double));
  r.path_points = (size_t*)malloc(2 * r.path_count * sizeof(size_t));
  r.path_offsets = (size_t*)malloc((r.path_count + 1) * sizeof(size_t));
  r.path_vertices = (double*)malloc(3 * path_rows * sizeof(double));
  if (!r.point_id_offsets || !r.point_ids || !r.point_positions || !r.path_points ||
      !r.path_offsets || !r.path_vertices) {
    analytic_references_free(&r);
    return CADINTERP_E_OUT_OF_MEMORY;
  }

  for (v = 0; v < b->vertex_count; ++v) {
    const int* q = b->vertices[v].index;
    const int count = vertex_edges(b, v, &r.point_ids[id_at + 2]);
    r.point_id_offsets[point] = id_at;
    r.point_ids[id_at] = 0;
    r.point_ids[id_at + 1] = b->vertices[v].id;
    id_at += 2 + (size_t)count;
    memcpy(&r.point_positions[3 * point],
           &positions[3 * analytic_grid_vertex(s->n, q[0], q[1], q[2])], 3 * sizeof(double));
    ++point;
  }

  for (e = 0; e < b->edge_count; ++e) {
    const analytic_brep_edge* edge = &b->edges[e];
    int from, to, dir[3];
    long m, step;
    int base[3];
    const size_t first_sample = point;
    edge_ends(b, edge, &from, &to);
    memcpy(base, b->vertices[from].index, sizeof(base));
    step = edge_steps(b, from, to, dir); /* grid steps per 1/segments of the edge */

    for (m = 1; m < segments; ++m) {
      long tz = 0, q;
      const int64_t lo = b->vertices[from].id, hi = b->vertices[to].id;
      while (!((m >> tz) & 1)) ++tz;
      d = levels - 1 - (int)tz; /* depth of the dyadic range whose midpoint is m / segments */
      q = m >> (tz + 1);
      r.point_id_offsets[point] = id_at;
      r.point_ids[id_at++] = 1;
      r.point_ids[id_at++] = edge->id;
      r.point_ids[id_at++] = lo;
      r.point_ids[id_at++] = hi;
      r.point_ids[id_at++] = -1;
      for (; d > 0; --d) r.point_ids[id_at++] = (q >> (d - 1)) & 1;
      grid_point(s, positions, base, dir, m * step, segments, &r.point_positions[3 * point]);
      ++point;
    }

    for (m = 0; m < segments; ++m) {
      /* grid steps from `base` (times `segments`) of the path's ends */
      const long a = m * step, c = (m + 1) * step;
      long g;
      r.path_points[2 * path] = m == 0 ? (size_t)from : first_sample + (size_t)(m - 1);
      r.path_points[2 * path + 1] = m + 1 == segments ? (size_t)to : first_sample + (size_t)m;
      r.path_offsets[path] = row;
      memcpy(&r.path_vertices[3 * row++], &r.point_positions[3 * r.path_points[2 * path]],
             3 * sizeof(double));
      /* grid vertices strictly between a and c, in the path's direction */
      for (g = a / segments + 1; g * segments < c; ++g) {
        int q[3], k;
        for (k = 0; k < 3; ++k) q[k] = base[k] + dir[k] * (int)g;
        memcpy(&r.path_vertices[3 * row++],
               &positions[3 * analytic_grid_vertex(s->n, q[0], q[1], q[2])], 3 * sizeof(double));
      }
      memcpy(&r.path_vertices[3 * row++], &r.point_positions[3 * r.path_points[2 * path + 1]],
             3 * sizeof(double));
      ++path;
    }
  }
  r.point_id_offsets[point] = id_at;
  r.path_offsets[path] = row;

  *out = r;
  return CADINTERP_OK;
}

void analytic_references_free(analytic_references* references) {
  if (!references) return;
  free(references->point_id_offsets);
  free(references->point_ids);
  free(references->point_positions);
  free(references->path_points);
  free(references->path_offsets);
  free(references->path_vertices);
  memset(references, 0, sizeof(*references));
}
