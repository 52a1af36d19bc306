/* cadinterp builder: precompute a parametric model into an asset (.cadi) by calling a host CAD
 * kernel through plain C callbacks (paper §4.2: adaptive sampling on a K-d tree).
 *
 * C99, stable ABI; the conventions of cadinterp.h apply (status codes, no exception crosses the
 * interface, outputs untouched on failure, libigl-style shapes). Link libcadinterp_builder.
 *
 * How a build works:
 * 1. The builder asks the host for samples at parameter vectors x. For each x it calls
 *    regenerate(x), then references(x), then simulate(x, mesh) if the host has one. The host
 *    writes what it computed into a builder-owned cadinterp_sample with the cadinterp_sample_*
 *    functions below; no memory allocated by the host crosses the interface, and the host may free
 *    its arrays as soon as a cadinterp_sample_* call returns (the builder copies).
 * 2. A callback that returns a status other than CADINTERP_OK, throws (C++ hosts: the builder
 *    catches), or produces an invalid mesh (no vertices or tets, non-finite coordinates, indices
 *    out of range, inverted or degenerate tets) makes that x infeasible, with the host's message
 *    (cadinterp_sample_set_message) or the builder's. The build continues; the asset records the
 *    infeasible points and the runtime answers CADINTERP_E_INFEASIBLE near them.
 * 3. Samples are kept in a sample store (an SQLite file) when one is given, so that a build that
 *    is killed at any moment resumes without evaluating any finished sample again, and writes a
 *    byte-identical asset. Builds are deterministic for the same host and options, whatever the
 *    thread count.
 *
 * Control-point IDs (the references callback). Meshes of different combinatorics are mapped
 * onto each other (paper §6) through control points that are matched ONLY by equal IDs, so an ID
 * must name the same B-rep entity wherever that entity's topology is unchanged, and must differ
 * otherwise. An ID is a vector of int64 built from stable entity ids (derived from the model's
 * feature history, never from enumeration order):
 *   - a B-rep vertex:  { 0, vertex id, sorted ids of its adjacent edges... }
 *   - a B-rep edge:    { 1, edge id, sorted ids of its two end vertices... }, identifying the
 *                      edge itself; its interior samples extend it by hierarchical subdivision
 *                      of the edge's parameter range, oriented from its lower-id end vertex to its
 *                      higher-id one: { 1, edge id, end ids..., -1 } is the midpoint of the range,
 *                      and { ..., -1, i_1, ..., i_n } (each i in {0,1}) the midpoint of the
 *                      sub-range reached by taking the lower (0) or upper (1) half n times; so
 *                      n levels give the points at j / 2^(n+1), and an ID says exactly where on
 *                      the edge its point lies, whatever the edge's length.
 * Paths connect two control points by a polyline on the boundary surface (CAD edges, or their
 * pieces between edge samples). Boundary-condition regions name a set of triangle face tags.
 */
#ifndef CADINTERP_BUILDER_H
#define CADINTERP_BUILDER_H

#include <stddef.h>
#include <stdint.h>

#include "cadinterp/cadinterp.h"
#include "cadinterp/cadinterp_status.h"

/* Marks a declaration kept for one release under an old name; compilers warn where it is used.
 * Define CADINTERP_DEPRECATED(msg) as empty before including this header to silence them. */
#ifndef CADINTERP_DEPRECATED
#if defined(_MSC_VER)
#define CADINTERP_DEPRECATED(msg) __declspec(deprecated(msg))
#elif defined(__GNUC__) || defined(__clang__)
#define CADINTERP_DEPRECATED(msg) __attribute__((deprecated(msg)))
#else
#define CADINTERP_DEPRECATED(msg)
#endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/** What one host evaluation produced, written by the host's callbacks (builder-owned, opaque). */
typedef struct cadinterp_sample cadinterp_sample;
/** A build in progress or finished: options, host, report and last error (opaque). */
typedef struct cadinterp_builder cadinterp_builder;

/* ---- Versions ---------------------------------------------------------------------------- */

/** Version "MAJOR.MINOR.PATCH" of the builder library actually linked (static storage; never
 * NULL). It may differ from the runtime's cadinterp_version when the two libraries come from
 * different releases. Thread-safe. */
CADINTERP_API const char* cadinterp_builder_version(void);
/** CADINTERP_VERSION_NUMBER of the builder library actually linked. Thread-safe. */
CADINTERP_API unsigned cadinterp_builder_version_number(void);

/* ---- Writing a sample (called by the host from its callbacks) ---------------------------- */

/**
 * Sets the sample's tet mesh and boundary triangles (regenerate). Copies the arrays.
 * @param[in] vertices        #V by 3 positions
 * @param[in] tets            #T by 4 vertex indices, positive orientation (det > 0)
 * @param[in] triangles       #F by 3 vertex indices, counter-clockwise seen from outside
 * @param[in] triangle_tags   #F face tags (the B-rep face each triangle lies on)
 * @return CADINTERP_E_INVALID_ARGUMENT (NULL arrays with nonzero counts, a mesh already set,
 *         counts above 2^31), CADINTERP_E_OUT_OF_MEMORY. Mesh validity is checked after the
 *         callback returns, not here.
 * Thread-safety: one thread per sample (the builder calls a host callback with one sample).
 */
CADINTERP_API cadinterp_status
cadinterp_sample_set_mesh(cadinterp_sample* sample, const double* vertices, size_t vertex_count,
                          const uint32_t* tets, size_t tet_count, const uint32_t* triangles,
                          const int32_t* triangle_tags, size_t triangle_count);

/** Adds a control point (references). @param[in] id id_length int64 (see the ID scheme above;
 * 1 <= id_length <= 64); @param[in] position 3 doubles. An ID given twice in one sample is
 * CADINTERP_E_INVALID_ARGUMENT. */
CADINTERP_API cadinterp_status cadinterp_sample_add_point(cadinterp_sample* sample,
                                                          const int64_t* id, size_t id_length,
                                                          const double* position);

/** Adds a path on the boundary between control points a and b (references).
 * @param[in] polyline #P by 3 positions from a to b, P >= 2. */
CADINTERP_API cadinterp_status cadinterp_sample_add_path(cadinterp_sample* sample,
                                                         const int64_t* id_a, size_t id_a_length,
                                                         const int64_t* id_b, size_t id_b_length,
                                                         const double* polyline,
                                                         size_t point_count);

/** Adds a boundary-condition region (references): a name unique in the sample, a kind
 * ("fixed", "force", "heat", ...; may be NULL), and the face tags it covers. */
CADINTERP_API cadinterp_status cadinterp_sample_add_region(cadinterp_sample* sample,
                                                           const char* name, const char* kind,
                                                           const int32_t* face_tags,
                                                           size_t face_tag_count);

/** Adds a named field (simulate). @param[in] values #V (CADINTERP_PER_VERTEX) or #T
 * (CADINTERP_PER_TET) by components doubles, 1 <= components <= 16; `count` is #V or #T. Every
 * feasible sample of a build must give the same fields (names, locations, components) in the
 * same order; a sample that differs is infeasible. */
CADINTERP_API cadinterp_status cadinterp_sample_add_field(cadinterp_sample* sample,
                                                          const char* name,
                                                          cadinterp_field_location location,
                                                          int components, const double* values,
                                                          size_t count);

/**
 * Sets the unit of the field called `name`, added before by cadinterp_sample_add_field: free
 * text such as "MPa", "mm", "K" (UTF-8, copied; "" clears it). The asset stores it per field
 * (format 1.1) and the runtime returns it from cadinterp_field_unit. A separate call so that
 * cadinterp_sample_add_field and the hosts calling it stay as they are; the build takes the
 * units of the sample it takes the field list from.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument or an empty name;
 * CADINTERP_E_NOT_FOUND when the sample has no field of that name.
 */
CADINTERP_API cadinterp_status cadinterp_sample_set_field_unit(cadinterp_sample* sample,
                                                               const char* name, const char* unit);

/** Sets the message recorded with an infeasible sample (why the host failed). Copies it. */
CADINTERP_API cadinterp_status cadinterp_sample_set_message(cadinterp_sample* sample,
                                                            const char* message);

/* ---- The host ---------------------------------------------------------------------------- */

/** Regenerates the model at x (K doubles) and writes its mesh into `out`. */
typedef cadinterp_status (*cadinterp_regenerate_fn)(void* user, const double* x,
                                                    cadinterp_sample* out);
/** Writes control points, paths and boundary-condition regions of the model at x into `out`
 * (the mesh written by regenerate is already set on it). */
typedef cadinterp_status (*cadinterp_references_fn)(void* user, const double* x,
                                                    cadinterp_sample* out);

/** The mesh regenerate wrote, as simulate sees it (pointers valid during the call). */
typedef struct cadinterp_host_mesh {
  size_t vertex_count;
  const double* vertices; /**< #V by 3 */
  size_t tet_count;
  const uint32_t* tets; /**< #T by 4 */
  size_t triangle_count;
  const uint32_t* triangles;    /**< #F by 3 */
  const int32_t* triangle_tags; /**< #F */
} cadinterp_host_mesh;

/** Simulates on the regenerated mesh and adds fields to `out` (optional callback). */
typedef cadinterp_status (*cadinterp_simulate_fn)(void* user, const double* x,
                                                  const cadinterp_host_mesh* mesh,
                                                  cadinterp_sample* out);

typedef struct cadinterp_parameter_desc {
  const char* name;    /**< non-empty */
  const char* unit;    /**< may be NULL */
  double lower, upper; /**< finite, lower < upper */
} cadinterp_parameter_desc;

typedef struct cadinterp_host {
  size_t struct_size; /**< sizeof(cadinterp_host): lets the struct grow */
  const char* name;   /**< recorded in the asset's provenance */
  /** Identity of the model and its settings (e.g. "wrench v3, mesh size 2 mm"). A sample store
   * written with another name, identity or parameter box is refused, never reused. */
  const char* identity;
  int parameter_count; /**< K, 1..8 */
  const cadinterp_parameter_desc* parameters;
  void* user; /**< passed to every callback */
  cadinterp_regenerate_fn regenerate;
  cadinterp_references_fn references; /**< may be NULL (no references) */
  cadinterp_simulate_fn simulate;     /**< may be NULL (no fields) */
  /** Nonzero when the callbacks may run concurrently for different x (each with its own
   * sample); zero makes the builder call the host from one thread at a time. */
  int thread_safe;
} cadinterp_host;

/**
 * Entry point of a host shared library (what `cadinterp build --host lib.so` loads): a function
 * exported under the name CADINTERP_HOST_ENTRY_NAME that returns the host of the model named
 * `model` (NULL or "": the library's default model) configured by `options` ("key=value" pairs
 * separated by ',' ; NULL or "": defaults), or NULL with *error set to a message in static or
 * library-owned storage. The returned host and its strings stay valid until the library is
 * unloaded; calling the entry again may return a new host.
 */
typedef const cadinterp_host* (*cadinterp_host_entry_fn)(const char* model, const char* options,
                                                         const char** error);
#define CADINTERP_HOST_ENTRY_NAME "cadinterp_host_entry"

/* ---- Options, progress, report ------------------------------------------------------------ */

typedef struct cadinterp_progress {
  int samples_done;   /**< host evaluations finished (or read from the store) so far */
  int samples_queued; /**< known to be needed next; the total grows as the tree refines */
  int elements;       /**< leaves of the K-d tree so far */
  double seconds;     /**< since the build started */
  double eta_seconds; /**< estimate for the known work, < 0 when unknown */
} cadinterp_progress;

/** Progress callback: return nonzero to cancel the build (cadinterp_builder_run then returns
 * CADINTERP_E_CANCELLED; the samples finished so far stay in the store). Called from the thread
 * that runs cadinterp_builder_run. */
typedef int (*cadinterp_progress_fn)(void* user, const cadinterp_progress* progress);

typedef struct cadinterp_build_options {
  size_t struct_size; /**< sizeof(cadinterp_build_options) */
  int degree;         /**< 1 (linear, default) or 3 (cubic) */
  /** Geometric error target: symmetric Hausdorff distance between the interpolated and the true
   * boundary surface, relative to the bounding-box diagonal (default 1e-3). */
  double geometry_tolerance;
  /** Field error target: max |interpolated - true| relative to the field's range of values in
   * the true sample (default 1e-2). */
  double field_tolerance;
  int max_samples;        /**< no refinement starts beyond this many samples (default 256) */
  int max_depth;          /**< splits per direction (default 8) */
  int threads;            /**< host evaluations in parallel; 0: hardware concurrency (default 0) */
  const char* store_path; /**< sample store file; NULL: keep samples in memory only */
  /** Largest absolute error the codec may add to positions, in model units; 0 (default) is
   * lossless. */
  double position_max_abs_error;
  cadinterp_progress_fn progress; /**< may be NULL */
  void* progress_user;
  /** Fields of a sample mapped onto another sample's mesh (paper §6; every term of an element
   * whose mesh differs from the element's canonical one). 0 (default): the sample's own fields,
   * carried over by barycentric interpolation at the mapped points. Nonzero: the host's
   * simulate at the sample's x on the mapped mesh itself, its boundary-condition faces found
   * through the canonical sample's regions (the paper's consistent boundary regions), so that
   * every term of an element is one discretization of its own shape and the blend holds no
   * difference between two meshes' solutions. One more simulate per mapped term; where it fails
   * the carried fields stay (counted in cadinterp_build_stages). Needs a host with simulate. */
  int simulate_mapped;
  /** Rounds of canonical refinement (default 3; 0: none). A term mapped onto its element's
   * canonical mesh keeps that mesh's combinatorics, so where the term's shape bends under a
   * canonical triangle (a hole's round wall where the canonical sample has a flat face) the
   * mapped triangle is a chord of it. Where some term's mapped boundary departs from its own
   * boundary by more than 0.7 x geometry_tolerance, the element's canonical mesh gets those
   * boundary edges bisected (every tet around one split in two, no interior vertex added) and
   * every term is mapped again onto it, for at most this many rounds, each kept only if every
   * term maps and the departure falls, adding at most half the canonical's vertex count. The
   * asset then stores that element on the refined mesh (counted in cadinterp_build_stages). */
  int canonical_refinement;
} cadinterp_build_options;

/** Fills `options` with the defaults above (struct_size included). */
CADINTERP_API void cadinterp_build_options_init(cadinterp_build_options* options);

typedef struct cadinterp_build_report {
  size_t struct_size;    /**< sizeof(cadinterp_build_report), set by the caller */
  int samples;           /**< basis samples of the asset */
  int host_evaluations;  /**< distinct points evaluated by the host in this run */
  int store_hits;        /**< points read from the sample store instead */
  int infeasible_points; /**< points where the host failed */
  int elements;          /**< leaf elements */
  int infeasible_elements;
  int stored_meshes;    /**< position arrays written (sum of terms over elements) */
  int budget_exhausted; /**< nonzero: max_samples stopped refinement above tolerance */
  double max_error;     /**< largest final element error, relative to its target (<= 1 met) */
  double host_seconds;  /**< summed over host evaluations of this run */
  double wall_seconds;
  uint64_t asset_bytes;
} cadinterp_build_report;

/* ---- Building ------------------------------------------------------------------------------ */

/**
 * Creates a builder for `host` with `options` (NULL: defaults). Both are copied (the host's
 * strings and parameter array too; `user` is kept as a pointer and must outlive the builder).
 * @return CADINTERP_E_INVALID_ARGUMENT with a message for an inconsistent host or options;
 *         *out is NULL then and the message is available from cadinterp_builder_create_error().
 * Thread-safety: safe; the builder is used by one thread at a time.
 */
CADINTERP_API cadinterp_status cadinterp_builder_create(const cadinterp_host* host,
                                                        const cadinterp_build_options* options,
                                                        cadinterp_builder** out);
/** Message of the calling thread's last failed cadinterp_builder_create (never NULL). */
CADINTERP_API const char* cadinterp_builder_create_error(void);
/** Deprecated name of cadinterp_builder_create_error (a create, not an open); same result. Kept
 * exported for one release, then removed. */
CADINTERP_DEPRECATED("use cadinterp_builder_create_error")
CADINTERP_API const char* cadinterp_builder_open_error(void);
/** Destroys a builder; NULL is a no-op. */
CADINTERP_API void cadinterp_builder_destroy(cadinterp_builder* builder);

/**
 * Runs the build and writes the asset to `output_path` (written to a temporary name and
 * renamed, so a killed build never leaves a partial asset under that name). The temporary file
 * is created and removed once before the build starts, so an output that cannot be written (a
 * missing directory, no permission) fails at once with CADINTERP_E_IO, before any host call.
 * @return CADINTERP_OK; CADINTERP_E_CANCELLED; CADINTERP_E_IO (store or output);
 *         CADINTERP_E_STORE_MISMATCH (the store belongs to another host, identity or box);
 *         CADINTERP_E_INFEASIBLE (no element could be built: the host failed everywhere, or
 *         no element's samples could be mapped onto its canonical mesh); CADINTERP_E_OUT_OF_MEMORY.
 */
CADINTERP_API cadinterp_status cadinterp_builder_run(cadinterp_builder* builder,
                                                     const char* output_path);
/** The report of the last run, finished or failed (zeros before the first). After a failure it
 * counts what was done before it: host_evaluations, store_hits, infeasible_points; `samples` is
 * the points requested so far when the refinement did not finish, `elements` the leaves so far.
 * Fills at most out->struct_size bytes (grow-by-addition) and sets out->struct_size to the bytes
 * filled. */
CADINTERP_API cadinterp_status cadinterp_builder_report(const cadinterp_builder* builder,
                                                        cadinterp_build_report* out);

/** Stage times and counts of a run, beside cadinterp_build_report. */
typedef struct cadinterp_build_stages {
  size_t struct_size;     /**< sizeof(cadinterp_build_stages), set by the caller */
  int points_requested;   /**< distinct sample points the refinement asked for */
  int infeasible_reasons; /**< distinct messages listed by cadinterp_builder_infeasible_reason */
  int other_infeasible_points; /**< infeasible points whose message is not listed */
  double store_seconds;        /**< opening the sample store */
  double sampling_seconds;     /**< waves of sample points: store reads, host, store writes */
  double refinement_seconds;   /**< error tests of the adaptive refinement (mapping included) */
  double elements_seconds;     /**< canonical meshes, terms mapped into them, asset content */
  double write_seconds;        /**< encoding and writing the asset */
  int unmapped_elements; /**< refused elements whose samples are all feasible: a term could not
                              be mapped onto the canonical mesh (the other refused elements of
                              cadinterp_build_report have an infeasible sample) */
  /** With simulate_mapped: mapped terms whose fields the host simulated on the mapped mesh, and
   * those where it failed (they keep the carried fields). A map evicted from the builder's
   * cache and needed again counts again, as do the terms of an element whose canonical mesh was
   * refined (canonical_refinement: simulated again on the refined mesh). */
  int mapped_simulated;
  int mapped_simulate_failures;
  /** The host's message for the first of those failures ("" if none); valid until the next run
   * or destroy. */
  const char* first_mapped_simulate_failure;
  /** canonical_refinement: elements whose canonical mesh was refined, and the vertices added to
   * their canonical meshes in all. */
  int refined_elements;
  int refined_vertices;
} cadinterp_build_stages;

/** Stage times and counts of the last run, finished or failed. Fills at most
 * out->struct_size bytes (grow-by-addition). */
CADINTERP_API cadinterp_status cadinterp_builder_stages(const cadinterp_builder* builder,
                                                        cadinterp_build_stages* out);

/** The last run's index-th distinct reason for infeasible points (first met first, at most 8):
 * the host's message (valid until the next run or destroy) and how many points gave it.
 * @return CADINTERP_E_INVALID_ARGUMENT past the last one. */
CADINTERP_API cadinterp_status cadinterp_builder_infeasible_reason(const cadinterp_builder* builder,
                                                                   int index, const char** message,
                                                                   int* count);
/** Message of the builder's last failed call ("" if none); valid until the next call. */
CADINTERP_API const char* cadinterp_builder_error(const cadinterp_builder* builder);

#ifdef __cplusplus
}
#endif

#endif /* CADINTERP_BUILDER_H */
