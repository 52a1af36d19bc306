/* Tet mesh of a structured hexahedral grid.
 *
 * Every cell is split into the 6 tets of its Kuhn (Freudenthal) subdivision: all share the
 * cell's diagonal from corner (0,0,0) to (1,1,1), and each walks from (0,0,0) to (1,1,1) adding
 * one unit step per axis in the order of one permutation of the axes. Every quad face of a cell
 * is then cut along the diagonal from its lowest to its highest corner, the same diagonal from
 * both sides, so neighbouring cells conform without any bookkeeping, and the boundary triangles
 * use that same diagonal.
 */
#include <stdlib.h>
#include <string.h>

#include "analytic_internal.h"

/* The unit-step orders; det[e_p0, e_p1, e_p2] is the permutation's sign, which decides whether
 * the tet's vertices need swapping to come out positively oriented. */
static const int kPermutations[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                        {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
static const int kPermutationSign[6] = {1, 1, 1, -1, -1, -1};

cadinterp_status analytic_shape_mesh(const analytic_shape* s, analytic_mesh* out) {
  const int* n = s->n;
  const size_t vertex_count = (size_t)(n[0] + 1) * (size_t)(n[1] + 1) * (size_t)(n[2] + 1);
  const size_t cell_count = (size_t)n[0] * (size_t)n[1] * (size_t)n[2];
  const size_t triangle_count =
      4 * ((size_t)n[0] * (size_t)n[1] + (size_t)n[1] * (size_t)n[2] + (size_t)n[2] * (size_t)n[0]);
  analytic_mesh m;
  size_t t = 0, f = 0;
  int ijk[3], axis;

  m.vertex_count = vertex_count;
  m.tet_count = 6 * cell_count;
  m.triangle_count = triangle_count;
  m.vertices = (double*)malloc(3 * vertex_count * sizeof(double));
  m.tets = (uint32_t*)malloc(4 * m.tet_count * sizeof(uint32_t));
  m.triangles = (uint32_t*)malloc(3 * triangle_count * sizeof(uint32_t));
  m.triangle_tags = (int32_t*)malloc(triangle_count * sizeof(int32_t));
  if (!m.vertices || !m.tets || !m.triangles || !m.triangle_tags) {
    analytic_mesh_free(&m);
    return CADINTERP_E_OUT_OF_MEMORY;
  }

  for (ijk[2] = 0; ijk[2] <= n[2]; ++ijk[2])
    for (ijk[1] = 0; ijk[1] <= n[1]; ++ijk[1])
      for (ijk[0] = 0; ijk[0] <= n[0]; ++ijk[0])
        analytic_shape_position(s, ijk,
                                &m.vertices[3 * analytic_grid_vertex(n, ijk[0], ijk[1], ijk[2])]);

  for (ijk[2] = 0; ijk[2] < n[2]; ++ijk[2])
    for (ijk[1] = 0; ijk[1] < n[1]; ++ijk[1])
      for (ijk[0] = 0; ijk[0] < n[0]; ++ijk[0]) {
        int p;
        for (p = 0; p < 6; ++p) {
          int corner[3], v;
          uint32_t* tet = &m.tets[4 * t++];
          corner[0] = ijk[0];
          corner[1] = ijk[1];
          corner[2] = ijk[2];
          tet[0] = (uint32_t)analytic_grid_vertex(n, corner[0], corner[1], corner[2]);
          for (v = 0; v < 3; ++v) {
            ++corner[kPermutations[p][v]];
            tet[v + 1] = (uint32_t)analytic_grid_vertex(n, corner[0], corner[1], corner[2]);
          }
          if (kPermutationSign[p] < 0) {
            const uint32_t swap = tet[2];
            tet[2] = tet[3];
            tet[3] = swap;
          }
        }
      }

  /* Boundary quads on the plane of `axis` = 0 or n[axis], spanned by the next two axes in
   * cyclic order (b, c), so corners 00 -> 10 -> 11 -> 01 turn counter-clockwise about +axis. */
  for (axis = 0; axis < 3; ++axis) {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    int side;
    for (side = 0; side < 2; ++side) {
      int cell[3];
      cell[axis] = side ? n[axis] - 1 : 0;
      for (cell[c] = 0; cell[c] < n[c]; ++cell[c])
        for (cell[b] = 0; cell[b] < n[b]; ++cell[b]) {
          int q[3];
          uint32_t v00, v10, v11, v01;
          uint32_t* tri = &m.triangles[3 * f];
          q[axis] = side ? n[axis] : 0;
          q[b] = cell[b];
          q[c] = cell[c];
          v00 = (uint32_t)analytic_grid_vertex(n, q[0], q[1], q[2]);
          ++q[b];
          v10 = (uint32_t)analytic_grid_vertex(n, q[0], q[1], q[2]);
          ++q[c];
          v11 = (uint32_t)analytic_grid_vertex(n, q[0], q[1], q[2]);
          --q[b];
          v01 = (uint32_t)analytic_grid_vertex(n, q[0], q[1], q[2]);
          /* Outward is +axis on the far side, -axis on the near side. */
          tri[0] = v00;
          tri[1] = side ? v10 : v11;
          tri[2] = side ? v11 : v10;
          tri[3] = v00;
          tri[4] = side ? v11 : v01;
          tri[5] = side ? v01 : v11;
          /* half 0 is (v00, v10, v11), half 1 (v00, v11, v01), whichever the winding */
          m.triangle_tags[f] = analytic_shape_triangle_tag(s, axis, side, cell, 0);
          m.triangle_tags[f + 1] = analytic_shape_triangle_tag(s, axis, side, cell, 1);
          f += 2;
        }
    }
  }

  *out = m;
  return CADINTERP_OK;
}

void analytic_mesh_free(analytic_mesh* mesh) {
  if (!mesh) return;
  free(mesh->vertices);
  free(mesh->tets);
  free(mesh->triangles);
  free(mesh->triangle_tags);
  memset(mesh, 0, sizeof(*mesh));
}
