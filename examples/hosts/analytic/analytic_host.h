/* The analytic host: parametric solids generated in code (no CAD kernel), with closed-form
 * fields, for the CLI (`cadinterp build --host libcadinterp_host_analytic.so`) and the
 * end-to-end tests. Plain C99.
 *
 * Models (README.md has parameters, units and ranges):
 *   "bracket" (default): a bent sheet-metal bracket whose mesh combinatorics never change;
 *   "plate": a cantilever plate whose mesh resolution follows its size, so its vertex count
 *            changes across the parameter box;
 *   "foldplate": the plate whose top face folds along its diagonal when fold > 0, so its B-rep
 *            topology changes too (a 13th edge, a 7th face).
 *
 * Only cadinterp_host_entry is exported from the shared library. The analytic_model_* functions
 * are what the host's callbacks are thin wrappers of; tests link the static library and call them
 * directly, without the builder, and use analytic_model_field_at as the closed-form truth.
 *
 * Thread-safety: every function may be called concurrently; an analytic_model is immutable after
 * analytic_model_create. Everything is deterministic.
 */
#ifndef CADINTERP_ANALYTIC_HOST_H
#define CADINTERP_ANALYTIC_HOST_H

#include <stddef.h>
#include <stdint.h>

#include "cadinterp/cadinterp_builder.h"

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__) || defined(__clang__)
#define ANALYTIC_HOST_EXPORT __attribute__((visibility("default")))
#else
#define ANALYTIC_HOST_EXPORT
#endif

/**
 * The library's entry point (cadinterp_host_entry_fn, CADINTERP_HOST_ENTRY_NAME).
 * @param[in] model    "bracket", "plate", "foldplate"; NULL or "" is "bracket"
 * @param[in] options  "key=value" pairs separated by ','; NULL or "": defaults. Keys:
 *                     cells=N (bracket, 1..64), edge=MM (plate, foldplate, 0.5..100, up to 3
 *                     decimals),
 *                     levels=D (0..6 edge subdivision levels), fail_region=0|1|2;
 *                     run-time only (not in the identity, results unchanged): sleep_ms=N
 *                     (sleep per regenerate), kill_after=N (the process's (N+1)th regenerate
 *                     kills the process with SIGKILL: a crashing kernel, for tests)
 * @param[out] error   on failure, a static message (may be NULL)
 * @return a host valid until the library is unloaded (the same host for the same model and
 *         options), or NULL for an unknown model, malformed option or out of memory.
 * Thread-safety: safe.
 */
ANALYTIC_HOST_EXPORT const cadinterp_host* cadinterp_host_entry(const char* model,
                                                                const char* options,
                                                                const char** error);

/** A model with its options (opaque; immutable but for kill_after's call count). */
typedef struct analytic_model analytic_model;

/** Creates a model like cadinterp_host_entry does, owned by the caller; NULL with a static
 * message in *error (may be NULL) on failure. */
analytic_model* analytic_model_create(const char* model, const char* options, const char** error);
/** Destroys a model; NULL is a no-op. */
void analytic_model_destroy(analytic_model* model);
/** The model behind a host returned by cadinterp_host_entry; NULL for any other host. */
const analytic_model* analytic_host_model(const cadinterp_host* host);

const char* analytic_model_name(const analytic_model* model);
/** Model, version and options, e.g. "analytic plate v1 (edge=5000 um, levels=2, fail_region=0)". */
const char* analytic_model_identity(const analytic_model* model);
int analytic_model_parameter_count(const analytic_model* model);
/** K descriptors (static storage). */
const cadinterp_parameter_desc* analytic_model_parameters(const analytic_model* model);
/** Nonzero when x lies in the region where fail_region (1 or 2) makes every callback fail. */
int analytic_model_in_fail_region(const analytic_model* model, const double* x);

/** A tet mesh with tagged boundary triangles; arrays owned by the struct (malloc). */
typedef struct analytic_mesh {
  size_t vertex_count;
  double* vertices; /**< #V by 3 */
  size_t tet_count;
  uint32_t* tets; /**< #T by 4, det[v1 - v0, v2 - v0, v3 - v0] > 0 */
  size_t triangle_count;
  uint32_t* triangles;    /**< #F by 3, counter-clockwise seen from outside */
  int32_t* triangle_tags; /**< #F face tags (B-rep faces, README.md) */
} analytic_mesh;

/**
 * The mesh of the model at x (K doubles), what the regenerate callback writes.
 * @param[out] out      filled on success (free with analytic_mesh_free), untouched otherwise
 * @param[out] message  on failure, a static message (may be NULL)
 * @return CADINTERP_OK; CADINTERP_E_OUTSIDE_DOMAIN (x not finite or outside the box);
 *         CADINTERP_E_INFEASIBLE (fail region); CADINTERP_E_OUT_OF_MEMORY.
 */
cadinterp_status analytic_model_mesh(const analytic_model* model, const double* x,
                                     analytic_mesh* out, const char** message);
/** Frees the arrays and zeroes the struct; NULL is a no-op. */
void analytic_mesh_free(analytic_mesh* mesh);

/** Control points and paths (cadinterp_builder.h ID scheme); arrays owned by the struct. */
typedef struct analytic_references {
  size_t point_count;
  size_t* point_id_offsets; /**< #points+1: the ID of point p is point_ids[o[p] .. o[p+1]) */
  int64_t* point_ids;
  double* point_positions; /**< #points by 3 */
  size_t path_count;
  size_t* path_points;   /**< #paths by 2: indices of the points a path runs from and to */
  size_t* path_offsets;  /**< #paths+1: path q has rows o[q] .. o[q+1] of path_vertices */
  double* path_vertices; /**< rows by 3 */
} analytic_references;

/** Control points and paths of the model at x, what the references callback writes. Same
 * statuses as analytic_model_mesh. */
cadinterp_status analytic_model_references(const analytic_model* model, const double* x,
                                           analytic_references* out, const char** message);
/** Frees the arrays and zeroes the struct; NULL is a no-op. */
void analytic_references_free(analytic_references* references);

/** A boundary-condition region (static storage). */
typedef struct analytic_region {
  const char* name;
  const char* kind;
  const int32_t* face_tags;
  size_t face_tag_count;
} analytic_region;

int analytic_model_region_count(const analytic_model* model);
/** Region i (0 <= i < count), NULL otherwise. */
const analytic_region* analytic_model_region(const analytic_model* model, int i);

/** A field the simulate callback adds, in this order (static storage). */
typedef struct analytic_field_desc {
  const char* name;
  const char* unit;
  cadinterp_field_location location;
  int components;
} analytic_field_desc;

int analytic_model_field_count(const analytic_model* model);
/** Field i (0 <= i < count), NULL otherwise. */
const analytic_field_desc* analytic_model_field(const analytic_model* model, int i);

/**
 * Values of field i on a mesh of the model at x, what the simulate callback writes: the
 * closed form (analytic_model_field_at) at each vertex, or at each tet's centroid.
 * @param[out] values  #V or #T by components
 * @return as analytic_model_mesh, and CADINTERP_E_INVALID_ARGUMENT for a bad field index.
 */
cadinterp_status analytic_model_field_values(const analytic_model* model, int field,
                                             const double* x, const cadinterp_host_mesh* mesh,
                                             double* values, const char** message);

/**
 * The closed-form truth: field i of the solid at x, at point p (3 doubles; a point of the solid,
 * or near it: the bracket projects p onto its sheet). Depends on p and x only, never on a mesh.
 * @param[out] value  `components` doubles
 * @return CADINTERP_OK, CADINTERP_E_OUTSIDE_DOMAIN (x), CADINTERP_E_INVALID_ARGUMENT (field, p).
 *         The fail region is ignored here: the truth exists everywhere in the box.
 */
cadinterp_status analytic_model_field_at(const analytic_model* model, int field, const double* x,
                                         const double* p, double* value);

#ifdef __cplusplus
}
#endif

#endif /* CADINTERP_ANALYTIC_HOST_H */
