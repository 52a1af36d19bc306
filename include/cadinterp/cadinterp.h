/* cadinterp runtime: open a precomputed asset (.cadi) and evaluate the interpolated shape, its
 * fields and their derivatives at any parameter vector x.
 *
 * C99, stable ABI. Conventions (apply to every function unless its comment says otherwise):
 * - Every fallible function returns a cadinterp_status; CADINTERP_OK is 0. On failure its outputs
 *   are left untouched and a message is available from cadinterp_workspace_error (calls that take
 *   a workspace) or cadinterp_open_error (cadinterp_open*).
 * - No C++ exception crosses this interface; out-of-memory is reported as a status.
 * - Thread-safety: an opened cadinterp_asset is immutable (but for its internal element cache,
 *   which is synchronized) and may be used by any number of threads at once. A
 *   cadinterp_workspace holds per-thread scratch: one thread at a time per workspace; create one
 *   per thread.
 * - Pointers returned in output structs point into the workspace (valid until the next call with
 *   that workspace or its destruction) or into the asset (valid until cadinterp_close), as stated.
 * - Shapes are written libigl-style: "#V by 3" is a row-major array of #V rows of 3 values.
 */
#ifndef CADINTERP_H
#define CADINTERP_H

#include <stddef.h>
#include <stdint.h>

#include "cadinterp/cadinterp_status.h"
#include "cadinterp/cadinterp_version.h"

#if defined(_WIN32)
#if defined(CADINTERP_BUILDING_LIBRARY)
#define CADINTERP_API __declspec(dllexport)
#else
#define CADINTERP_API __declspec(dllimport)
#endif
#else
#define CADINTERP_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/** An opened asset (opaque). */
typedef struct cadinterp_asset cadinterp_asset;
/** Per-thread evaluation scratch bound to one asset (opaque). */
typedef struct cadinterp_workspace cadinterp_workspace;

/* ---- Versions ---------------------------------------------------------------------------- */

/** Library version string "MAJOR.MINOR.PATCH" (static storage). Thread-safe. */
CADINTERP_API const char* cadinterp_version(void);
/** CADINTERP_VERSION_NUMBER of the library actually linked. Thread-safe. */
CADINTERP_API unsigned cadinterp_version_number(void);
/** Newest asset format this library reads: major and minor (either pointer may be NULL). */
CADINTERP_API void cadinterp_format_version(int* major, int* minor);
/** Fixed English text of a status (static storage; never NULL). Thread-safe. */
CADINTERP_API const char* cadinterp_status_string(cadinterp_status status);

/* ---- Opening ------------------------------------------------------------------------------- */

/**
 * Opens the asset file at `path` by memory-mapping it. Only the header and the index are read
 * and verified; meshes are decoded on demand, one element at a time. Cost is independent of the
 * size of the mesh data.
 * @param[in]  path  file name (NUL-terminated)
 * @param[out] out   the asset on success; untouched on failure
 * @return CADINTERP_OK or an error (message: cadinterp_open_error on this thread)
 */
CADINTERP_API cadinterp_status cadinterp_open(const char* path, cadinterp_asset** out);

/**
 * Opens an asset held in memory.
 * @param[in]  data  `size` bytes of a .cadi file
 * @param[in]  copy  nonzero: the bytes are copied; zero: the caller keeps them alive and unchanged
 *                   until cadinterp_close
 * @param[out] out   the asset on success; untouched on failure
 */
CADINTERP_API cadinterp_status cadinterp_open_memory(const void* data, size_t size, int copy,
                                                     cadinterp_asset** out);

/** Message of this thread's last failed cadinterp_open* ("" if none); valid until the next open
 *  call on this thread. */
CADINTERP_API const char* cadinterp_open_error(void);

/** Closes an asset; NULL is a no-op. Every workspace of the asset must be destroyed first. */
CADINTERP_API void cadinterp_close(cadinterp_asset* asset);

/* ---- Queries (thread-safe; strings live until cadinterp_close) ---------------------------- */

/** Number of parameters K (1..8), or 0 if asset is NULL. */
CADINTERP_API int cadinterp_dim(const cadinterp_asset* asset);
/** Basis degree: 1 (linear, C0) or 3 (cubic, C2), 0 if asset is NULL. */
CADINTERP_API int cadinterp_degree(const cadinterp_asset* asset);
/** Number of elements of the K-d tree, 0 if asset is NULL. */
CADINTERP_API int cadinterp_element_count(const cadinterp_asset* asset);
/** Format version of this asset's file. */
CADINTERP_API cadinterp_status cadinterp_asset_format(const cadinterp_asset* asset, int* major,
                                                      int* minor);

typedef struct cadinterp_parameter_info {
  const char* name;
  const char* unit;
  double lower, upper; /**< the parameter's range */
} cadinterp_parameter_info;

/** Parameter i (0 <= i < K). */
CADINTERP_API cadinterp_status cadinterp_parameter(const cadinterp_asset* asset, int i,
                                                   cadinterp_parameter_info* out);

typedef enum cadinterp_field_location {
  CADINTERP_PER_VERTEX = 0,
  CADINTERP_PER_TET = 1
} cadinterp_field_location;

typedef struct cadinterp_field_info {
  const char* name;
  cadinterp_field_location location;
  int components;
  double max_abs_error; /**< the codec's error bound on stored values (0: lossless) */
} cadinterp_field_info;

/** Number of fields (e.g. temperature, von Mises stress). */
CADINTERP_API int cadinterp_field_count(const cadinterp_asset* asset);
/** Field i (0 <= i < field count). */
CADINTERP_API cadinterp_status cadinterp_field(const cadinterp_asset* asset, int i,
                                               cadinterp_field_info* out);
/**
 * The unit of field i as free text ("MPa", "mm", "K", ... as the builder's host gave it), or ""
 * when the asset has none for it (every format 1.0 asset). A separate call rather than a member
 * of cadinterp_field_info, whose layout is part of the ABI.
 * @param[in]  asset  the asset
 * @param[in]  i      0 <= i < cadinterp_field_count(asset)
 * @param[out] unit   NUL-terminated UTF-8 owned by the asset, valid until cadinterp_close
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument or i out of range
 * (`*unit` untouched). Thread-safety: safe (the asset is immutable).
 */
CADINTERP_API cadinterp_status cadinterp_field_unit(const cadinterp_asset* asset, int i,
                                                    const char** unit);
/** Index of the field called `name`, CADINTERP_E_NOT_FOUND if none. */
CADINTERP_API cadinterp_status cadinterp_find_field(const cadinterp_asset* asset, const char* name,
                                                    int* index);

typedef struct cadinterp_region_info {
  const char* name;
  const char* kind;         /**< "fixed", "force", "heat", ... as the builder's host named it */
  const int32_t* face_tags; /**< the triangle tags the region covers */
  int face_tag_count;
} cadinterp_region_info;

/** Number of boundary-condition regions. */
CADINTERP_API int cadinterp_region_count(const cadinterp_asset* asset);
CADINTERP_API cadinterp_status cadinterp_region(const cadinterp_asset* asset, int i,
                                                cadinterp_region_info* out);

typedef struct cadinterp_provenance {
  const char* builder_version;
  const char* host;
  const char* options; /**< the build options, JSON */
} cadinterp_provenance;

CADINTERP_API cadinterp_status cadinterp_get_provenance(const cadinterp_asset* asset,
                                                        cadinterp_provenance* out);

/**
 * The element holding x, and whether it can be evaluated. Points on faces between elements are
 * assigned deterministically (to the upper side).
 * @param[in]  x        K values
 * @param[out] element  element index
 * @param[out] feasible 1 if eval at x succeeds, 0 if x is in an infeasible element (may be NULL)
 * @return CADINTERP_E_OUTSIDE_DOMAIN if x is outside the box or not finite
 */
CADINTERP_API cadinterp_status cadinterp_locate(const cadinterp_asset* asset, const double* x,
                                                int* element, int* feasible);

/** The builder's error estimate of the element holding x (relative to the model's bounding-box
 *  diagonal; negative if the builder did not measure it). */
CADINTERP_API cadinterp_status cadinterp_error_estimate(const cadinterp_asset* asset,
                                                        const double* x, double* error);

/** Number of parameter points where the builder's host failed (0 if asset is NULL). */
CADINTERP_API int cadinterp_infeasible_point_count(const cadinterp_asset* asset);
/**
 * Infeasible point i (0 <= i < count) as the builder recorded it.
 * @param[out] x        K doubles, real parameter coordinates
 * @param[out] message  the host's message (may be NULL; valid until cadinterp_close)
 * Thread-safety: safe.
 */
CADINTERP_API cadinterp_status cadinterp_infeasible_point(const cadinterp_asset* asset, int i,
                                                          double* x, const char** message);

/**
 * Sets the byte budget of the cache of decoded elements (default 256 MiB). Least recently used
 * elements are dropped beyond it; an element in use by a workspace stays alive until released.
 * A topology shared by several elements counts once; an element's field arrays are decoded (and
 * counted) on the first call that reads fields; the buffers of one dropped element may be kept
 * outside the budget for reuse by the next decode.
 */
CADINTERP_API cadinterp_status cadinterp_set_cache_budget(cadinterp_asset* asset, size_t bytes);

/* ---- Evaluation (one thread at a time per workspace) --------------------------------------- */

/** Creates a workspace for `asset` (which must outlive it). */
CADINTERP_API cadinterp_status cadinterp_workspace_create(const cadinterp_asset* asset,
                                                          cadinterp_workspace** out);
/** Destroys a workspace; NULL is a no-op. */
CADINTERP_API void cadinterp_workspace_destroy(cadinterp_workspace* ws);
/** Message of the last failed call made with `ws` ("" if none); valid until the next call. */
CADINTERP_API const char* cadinterp_workspace_error(const cadinterp_workspace* ws);

/** An evaluated mesh. Topology points into the workspace's reference to the element (valid
 *  until the next call with the workspace); arrays likewise. */
typedef struct cadinterp_mesh {
  int element;                  /**< the element holding x */
  uint32_t vertex_count;        /**< #V */
  uint32_t tet_count;           /**< #T */
  uint32_t triangle_count;      /**< #F */
  const uint32_t* tets;         /**< #T by 4 */
  const uint32_t* triangles;    /**< #F by 3, outward */
  const int32_t* triangle_tags; /**< #F face tags (see cadinterp_region) */
  const float* positions;       /**< #V by 3 */
  /** Per requested field (in request order): #V (or #T) by components values. */
  const float* const* fields;
} cadinterp_mesh;

/**
 * Evaluates the shape and the requested fields at x (paper Eq. 3: the element's samples blended
 * with weights psi_k(x)).
 * @param[in]  x            K parameter values
 * @param[in]  fields       indices of the fields to evaluate (may be NULL if field_count is 0)
 * @param[out] out          the mesh; untouched on failure
 * @return CADINTERP_E_OUTSIDE_DOMAIN, CADINTERP_E_INFEASIBLE, decoding errors, ...
 */
CADINTERP_API cadinterp_status cadinterp_eval(cadinterp_workspace* ws, const double* x,
                                              const int* fields, int field_count,
                                              cadinterp_mesh* out);

/**
 * cadinterp_eval restricted to chosen vertices and tets: the same blend (Eq. 3, same weights,
 * same term order) applied only to the rows asked for, for viewers that draw the boundary
 * surface and need neither the interior vertices nor every tet's field value (on a tet mesh the
 * boundary holds a small part of the vertices: 16k of 90k on the bracket of examples/explorer).
 *
 * `out` is filled as by cadinterp_eval (element, whole-mesh counts and topology), except that
 * out->positions holds vertex_subset_count rows of 3 (row i: vertex vertices[i]) and each
 * requested field vertex_subset_count rows (per-vertex fields, row i: vertices[i]) or
 * tet_subset_count rows (per-tet fields, row i: tets[i]) of its components. Ids may repeat and
 * come in any order. Rows equal cadinterp_eval's up to float rounding: bit for bit with the
 * portable kernel (WebAssembly); on x86-64 with AVX2 the whole-mesh kernel fuses multiply-adds.
 * The ids are checked against the element holding x (its #V and #T, which
 * only a previous call can tell: cadinterp_eval, or this one with empty subsets).
 * @param[in]  vertices  vertex ids (may be NULL if vertex_subset_count is 0)
 * @param[in]  tets      tet ids (may be NULL if tet_subset_count is 0)
 * @return as cadinterp_eval; CADINTERP_E_INVALID_ARGUMENT for a NULL array with a nonzero count,
 *         CADINTERP_E_OUT_OF_RANGE for an id >= #V (or #T) of the element holding x
 */
CADINTERP_API cadinterp_status cadinterp_eval_subset(cadinterp_workspace* ws, const double* x,
                                                     const uint32_t* vertices,
                                                     size_t vertex_subset_count,
                                                     const uint32_t* tets, size_t tet_subset_count,
                                                     const int* fields, int field_count,
                                                     cadinterp_mesh* out);

/** Derivatives of an evaluated mesh with respect to the parameters (Eq. 13). */
typedef struct cadinterp_mesh_grad {
  int element;
  uint32_t vertex_count;
  /** #V by 3: the positions at x (as cadinterp_eval), computed in the same pass. */
  const float* positions;
  /** K blocks of #V by 3: dpositions[d * 3 * #V + 3 * v + c] = d P_vc / d x_d. */
  const float* dpositions;
  /** Per requested field: K blocks of that field's values, laid out as in cadinterp_mesh. */
  const float* const* dfields;
} cadinterp_mesh_grad;

/**
 * The positions and their K derivative arrays (and the derivatives of the requested fields) at
 * x, in one pass over the stored samples. Cubic assets are C2 in x; linear assets are
 * continuous, and their derivative is taken from the element holding x.
 */
CADINTERP_API cadinterp_status cadinterp_grad(cadinterp_workspace* ws, const double* x,
                                              const int* fields, int field_count,
                                              cadinterp_mesh_grad* out);

/**
 * Vector-Jacobian product for optimizers: given dF/dP (#V by 3, the adjoint of the positions of
 * the mesh eval returns at x) and optionally the adjoints of requested fields, returns
 * dF/dx (K values) without forming the K derivative arrays.
 * @param[in]  dF_dpositions  #V by 3 (may be NULL: zero)
 * @param[in]  dF_dfields     per requested field, its adjoint array or NULL (may be NULL)
 * @param[out] dF_dx          K values
 */
CADINTERP_API cadinterp_status cadinterp_vjp(cadinterp_workspace* ws, const double* x,
                                             const float* dF_dpositions, const int* fields,
                                             const float* const* dF_dfields, int field_count,
                                             double* dF_dx);

/** Mass properties of the evaluated solid. */
typedef struct cadinterp_properties {
  double volume;
  double mass;         /**< density * volume */
  double area;         /**< boundary surface area */
  double frontal_area; /**< area projected along `direction`: silhouette area for convex bodies,
                            an upper bound otherwise (a drag proxy) */
  double centroid[3];
  double inertia[9]; /**< 3 by 3 row-major, about the centroid */
} cadinterp_properties;

/**
 * Derived quantities of the mesh at x, and optionally their derivatives with respect to x.
 * @param[in]  density    uniform density for mass and inertia
 * @param[in]  direction  3 values, the (unit) direction for the frontal area
 * @param[out] out        the quantities
 * @param[out] grad       NULL, or K structs: grad[d] holds the derivatives along x_d
 */
CADINTERP_API cadinterp_status cadinterp_properties_eval(cadinterp_workspace* ws, const double* x,
                                                         double density, const double* direction,
                                                         cadinterp_properties* out,
                                                         cadinterp_properties* grad);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* CADINTERP_H */
