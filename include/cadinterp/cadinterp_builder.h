/* cadinterp builder: precompute a parametric model into an asset (.cadi) by calling a host CAD
 * kernel through plain C callbacks (paper §4.2: adaptive sampling on a K-d tree).
 *
 * C99; the conventions of cadinterp.h apply (status codes, no exception crosses the interface,
 * outputs untouched on failure, libigl-style shapes). Link libcadinterp_builder.
 *
 * EXPERIMENTAL ABI (CADINTERP_BUILDER_ABI_VERSION, 0): unlike the runtime's frozen ABI 1, this
 * header may change incompatibly in any release while its version is 0 (the build sessions below
 * are its newest part and the likeliest to change); each change
 * is listed in CHANGELOG.md and the SONAME libcadinterp_builder.so.N changes with it, so a
 * program built against another builder ABI fails to load rather than misbehave. Integrators who
 * ship the builder should pin the library version and rebuild on upgrade. Assets the builder
 * writes are covered by the format's own compatibility rules (fileformat/SPEC.md), not by this.
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
#include "cadinterp/cadinterp_version.h"

#ifdef __cplusplus
extern "C" {
#endif

/** What one host evaluation produced, written by the host's callbacks. Builder-owned and opaque:
 * the builder creates one per evaluation and passes it to regenerate, references and simulate at
 * the same x; the pointer is valid only during those calls and must not be kept. */
typedef struct cadinterp_sample cadinterp_sample;
/** A build: its copied host and options, and the report and messages of its last run (opaque).
 * Created by cadinterp_builder_create, destroyed by cadinterp_builder_destroy. */
typedef struct cadinterp_builder cadinterp_builder;

/* ---- Versions ---------------------------------------------------------------------------- */

/** Version "MAJOR.MINOR.PATCH" of the builder library actually linked (static storage; never
 * NULL). It may differ from the runtime's cadinterp_version when the two libraries come from
 * different releases. Thread-safe. */
CADINTERP_API const char* cadinterp_builder_version(void);
/** CADINTERP_VERSION_NUMBER of the builder library actually linked. Thread-safe. */
CADINTERP_API unsigned cadinterp_builder_version_number(void);

/* ---- Writing a sample (called by the host from its callbacks) ----------------------------
 * Common to every cadinterp_sample_* function:
 * - Call it only from a callback that received `sample`, on that callback's thread, before the
 *   callback returns (one thread per sample; different samples may be written concurrently).
 * - Arrays and strings are copied before the call returns: the host keeps ownership of its
 *   memory and may free or reuse it at once.
 * - A failure leaves the sample as it was and records no message (the status says what was
 *   wrong): CADINTERP_E_INVALID_ARGUMENT as listed per function, always including a NULL
 *   `sample`; CADINTERP_E_OUT_OF_MEMORY; CADINTERP_E_INTERNAL for a bug. A callback that passes
 *   a failure on as its own return value makes its x infeasible.
 * - Counts are size_t and must be below 2^31. */

/**
 * Sets the sample's tet mesh and boundary triangles (regenerate). Copies the arrays.
 * @param[in] vertices        #V by 3 positions
 * @param[in] tets            #T by 4 vertex indices, positive orientation (det > 0)
 * @param[in] triangles       #F by 3 vertex indices, counter-clockwise seen from outside
 * @param[in] triangle_tags   #F face tags (the B-rep face each triangle lies on)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL array with a nonzero count, a
 *         count of 2^31 or more, or a mesh already set on the sample (once per sample, in
 *         regenerate: references and simulate receive it set). Mesh validity is checked after
 *         the callback returns, not here.
 */
CADINTERP_API cadinterp_status
cadinterp_sample_set_mesh(cadinterp_sample* sample, const double* vertices, size_t vertex_count,
                          const uint32_t* tets, size_t tet_count, const uint32_t* triangles,
                          const int32_t* triangle_tags, size_t triangle_count);

/** Adds a control point (references). @param[in] id id_length int64 (see the ID scheme above);
 * @param[in] position 3 doubles (checked finite after the callback returns). Copies both.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL id or position, id_length
 * outside 1..64, or an ID already added to this sample. */
CADINTERP_API cadinterp_status cadinterp_sample_add_point(cadinterp_sample* sample,
                                                          const int64_t* id, size_t id_length,
                                                          const double* position);

/** Adds a path on the boundary between control points a and b (references). Copies the IDs and
 * the polyline. @param[in] id_a, id_b as cadinterp_sample_add_point's id (1..64 values each);
 * @param[in] polyline #P by 3 positions from a to b, P = point_count >= 2.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL or out-of-range ID or polyline,
 * or point_count < 2 or >= 2^31. */
CADINTERP_API cadinterp_status cadinterp_sample_add_path(cadinterp_sample* sample,
                                                         const int64_t* id_a, size_t id_a_length,
                                                         const int64_t* id_b, size_t id_b_length,
                                                         const double* polyline,
                                                         size_t point_count);

/** Adds a boundary-condition region (references): a name unique in the sample, a kind
 * ("fixed", "force", "heat", ...; NULL means ""), and the #R face tags it covers (face_tags may
 * be NULL when face_tag_count is 0). Copies all three.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL or empty name, a name already
 * used in this sample, or NULL face_tags with a nonzero count. */
CADINTERP_API cadinterp_status cadinterp_sample_add_region(cadinterp_sample* sample,
                                                           const char* name, const char* kind,
                                                           const int32_t* face_tags,
                                                           size_t face_tag_count);

/** Adds a named field (simulate). Copies the name and values. @param[in] values #V
 * (CADINTERP_PER_VERTEX) or #T (CADINTERP_PER_TET) by components doubles; `count` is #V or #T
 * (checked against the mesh, and the values checked finite, after the callback returns). Every
 * feasible sample of a build must give the same fields (names, locations, components) in the
 * same order; a sample that differs is infeasible.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL or empty name, a name already
 * added to this sample, components outside 1..16, an unknown location, or NULL values with a
 * nonzero count. */
CADINTERP_API cadinterp_status cadinterp_sample_add_field(cadinterp_sample* sample,
                                                          const char* name,
                                                          cadinterp_field_location location,
                                                          int components, const double* values,
                                                          size_t count);

/**
 * Sets the unit of the field called `name`, added before by cadinterp_sample_add_field: free
 * text such as "MPa", "mm", "K" (UTF-8, copied; "" clears it). The asset stores it per field
 * (format 1.1) and the runtime returns it from cadinterp_field_unit. A separate call so that
 * cadinterp_sample_add_field keeps its signature; the build takes the units of the sample it
 * takes the field list from.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument or an empty name;
 * CADINTERP_E_NOT_FOUND when the sample has no field of that name.
 */
CADINTERP_API cadinterp_status cadinterp_sample_set_field_unit(cadinterp_sample* sample,
                                                               const char* name, const char* unit);

/**
 * Adds a scalar output: a quantity the host computed exactly at this sample's x (its B-rep
 * volume, a compliance, a maximum stress, ...). The asset stores it per sample (format 1.3) and
 * the runtime interpolates it with the element's basis weights (cadinterp_eval_outputs): no
 * mesh blend and no mapping error. Callable from any callback. Every feasible sample of a build
 * must give the same outputs (names, in the same order); a sample that differs is infeasible.
 * Copies the name and the unit.
 * @param[in] name   non-empty, unique in the sample (UTF-8)
 * @param[in] value  the value (checked finite after the callback returns: a non-finite value
 *                   makes the sample infeasible)
 * @param[in] unit   free text ("mm^3", "N mm"), or NULL / "" for none
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL sample or name, an empty name,
 *         or a name already added to this sample.
 */
CADINTERP_API cadinterp_status cadinterp_sample_add_output(cadinterp_sample* sample,
                                                           const char* name, double value,
                                                           const char* unit);

/** Sets the message recorded with an infeasible sample (why the host failed), replacing any
 * earlier one; it is used when the callback then returns a status other than CADINTERP_OK.
 * Copies it. @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL message. */
CADINTERP_API cadinterp_status cadinterp_sample_set_message(cadinterp_sample* sample,
                                                            const char* message);

/* ---- The host ----------------------------------------------------------------------------
 * The callbacks run on the builder's worker threads, not necessarily the thread that called
 * cadinterp_builder_run (unless cadinterp_build_options::host_on_calling_thread), and
 * concurrently for different x only when the host sets thread_safe.
 * `x` (K doubles) and `out` are valid only during the call. A return other than CADINTERP_OK,
 * a C++ exception (caught by the builder) or an invalid result makes x infeasible; the build
 * goes on. */

/** Regenerates the model at x (K doubles) and writes its mesh into `out`
 * (cadinterp_sample_set_mesh, exactly once). */
typedef cadinterp_status (*cadinterp_regenerate_fn)(void* user, const double* x,
                                                    cadinterp_sample* out);
/** Writes control points, paths and boundary-condition regions of the model at x into `out`
 * (the mesh written by regenerate is already set on it). */
typedef cadinterp_status (*cadinterp_references_fn)(void* user, const double* x,
                                                    cadinterp_sample* out);

/** The mesh simulate runs on (builder-owned; pointers valid during the call only): the one
 * regenerate wrote at x, or with simulate_mapped another sample's mesh mapped to x's shape. */
typedef struct cadinterp_host_mesh {
  size_t vertex_count;
  const double* vertices; /**< #V by 3 */
  size_t tet_count;
  const uint32_t* tets; /**< #T by 4 */
  size_t triangle_count;
  const uint32_t* triangles;    /**< #F by 3 */
  const int32_t* triangle_tags; /**< #F */
} cadinterp_host_mesh;

/** Simulates on `mesh` and adds fields to `out` (optional callback; `out` carries that mesh). */
typedef cadinterp_status (*cadinterp_simulate_fn)(void* user, const double* x,
                                                  const cadinterp_host_mesh* mesh,
                                                  cadinterp_sample* out);

/** One design parameter (one axis of the parameter box). Copied by cadinterp_builder_create. */
typedef struct cadinterp_parameter_desc {
  const char* name;    /**< non-empty */
  const char* unit;    /**< may be NULL */
  double lower, upper; /**< finite, lower < upper */
} cadinterp_parameter_desc;

/** The host CAD kernel as the builder sees it. cadinterp_builder_create copies the struct, its
 * strings and its parameter array, so they need to live only during that call; `user` and the
 * callbacks are kept as pointers and must stay valid until cadinterp_builder_destroy. */
typedef struct cadinterp_host {
  /** sizeof(cadinterp_host): lets the struct grow. create refuses a smaller value, since every
   * member up to thread_safe is read. */
  size_t struct_size;
  const char* name; /**< non-empty; recorded in the asset's provenance */
  /** Identity of the model and its settings (e.g. "wrench v3, mesh size 2 mm"; NULL means "").
   * A sample store written with another name, identity or parameter box is refused, never
   * reused. */
  const char* identity;
  int parameter_count;                        /**< K, 1..8 */
  const cadinterp_parameter_desc* parameters; /**< K descriptions */
  void* user;                                 /**< passed to every callback */
  cadinterp_regenerate_fn regenerate;         /**< required */
  cadinterp_references_fn references;         /**< may be NULL (no references) */
  cadinterp_simulate_fn simulate;             /**< may be NULL (no fields) */
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
 * unloaded; calling the entry again may return a new host. The library states whether the entry
 * may be called from several threads at once; the cadinterp tools call it from one.
 */
typedef const cadinterp_host* (*cadinterp_host_entry_fn)(const char* model, const char* options,
                                                         const char** error);
#define CADINTERP_HOST_ENTRY_NAME "cadinterp_host_entry"

/* ---- Options, progress, report ------------------------------------------------------------ */

/** What the progress callback is told (builder-owned; valid during the callback only). */
typedef struct cadinterp_progress {
  int samples_done;   /**< host evaluations finished (or read from the store) so far */
  int samples_queued; /**< known to be needed next; the total grows as the tree refines */
  int elements;       /**< leaves of the K-d tree so far */
  double seconds;     /**< since the build started */
  double eta_seconds; /**< estimate for the known work, < 0 when unknown */
} cadinterp_progress;

/** Progress callback: return nonzero to cancel the build (cadinterp_builder_run then returns
 * CADINTERP_E_CANCELLED; the samples finished so far stay in the store). Called from the thread
 * that runs cadinterp_builder_run, after each finished sample and each refinement wave, then
 * while the elements are mapped (every sample done, none queued, eta_seconds for the element
 * stage) between the terms that thread maps, so that a cancel takes effect within about one
 * mapping or one round of canonical refinement (a
 * session: see "Build sessions"); it must not call cadinterp_builder_* functions on the builder
 * that is running. */
typedef int (*cadinterp_progress_fn)(void* user, const cadinterp_progress* progress);

/** The most random points a build may ask to calibrate its error estimates
 * (cadinterp_build_options.calibration_points). */
#define CADINTERP_MAX_CALIBRATION_POINTS 100000

/** Options of a build. Fill it with cadinterp_build_options_init (the defaults), then change
 * members. cadinterp_builder_create copies it (and store_path); progress_user is kept as a
 * pointer. A caller built against an older, shorter struct sets struct_size to its own size and
 * gets the defaults for the members it does not know. */
typedef struct cadinterp_build_options {
  /** sizeof(cadinterp_build_options); at least offsetof(progress_user) + sizeof(void*). */
  size_t struct_size;
  int degree; /**< 1 (linear, default) or 3 (cubic) */
  /** Geometric error target: symmetric Hausdorff distance between the interpolated and the true
   * boundary surface, relative to the bounding-box diagonal (default 1e-3; > 0). */
  double geometry_tolerance;
  /** Field error target: max |interpolated - true| relative to the field's range of values in
   * the true sample (default 1e-2; > 0). Scalar outputs (cadinterp_sample_add_output) are held
   * to it too, relative to their magnitude (the largest |value| among the true and the
   * element's samples). */
  double field_tolerance;
  int max_samples; /**< no refinement starts beyond this many samples (default 256; >= 2) */
  int max_depth;   /**< splits per direction (default 8; 1..29) */
  /** Host evaluations in parallel, and the threads of the builder's own work (refinement tests,
   * elements, canonical refinement); 0: hardware concurrency (default 0). The asset's bytes do
   * not depend on it. */
  int threads;
  const char* store_path; /**< sample store file; NULL: keep samples in memory only */
  /** Largest absolute error the codec may add to positions, in model units; 0 (default) is
   * lossless; >= 0. */
  double position_max_abs_error;
  cadinterp_progress_fn progress; /**< may be NULL */
  void* progress_user;            /**< passed to progress; must stay valid during runs */
  /** Fields of a sample mapped onto another sample's mesh (paper §6; every term of an element
   * whose mesh differs from the element's canonical one). 0 (default): the sample's own fields,
   * carried over by barycentric interpolation at the mapped points. Nonzero: the host's
   * simulate at the sample's x on the mapped mesh itself, its boundary-condition faces found
   * through the canonical sample's regions (the paper's consistent boundary regions), so that
   * every term of an element is one discretization of its own shape and the blend holds no
   * difference between two meshes' solutions. One more simulate per mapped term; where it fails
   * the carried fields stay (counted in cadinterp_build_stages). Needs a host with simulate. */
  int simulate_mapped;
  /** Rounds of canonical refinement (default 3; 0: none; at most 20). A term mapped onto its
   * element's canonical mesh keeps that mesh's combinatorics, so where the term's shape bends
   * under a canonical triangle (a hole's round wall where the canonical sample has a flat face)
   * the mapped triangle is a chord of it. Where some term's mapped boundary departs from its own
   * boundary by more than 0.7 x geometry_tolerance, the element's canonical mesh gets those
   * boundary edges bisected (every tet around one split in two, no interior vertex added) and
   * every term is mapped again onto it, for at most this many rounds, each kept only if every
   * term maps and the departure falls, adding at most half the canonical's vertex count. The
   * asset then stores that element on the refined mesh (counted in cadinterp_build_stages). */
  int canonical_refinement;
  /** Nonzero: cadinterp_builder_run calls the host's callbacks only on the thread that called
   * it, one evaluation at a time (`threads` is then ignored), for kernels that must be called
   * from the thread that created them (many CAD kernels, COM single-threaded apartments). The
   * builder's own work runs on its threads meanwhile. 0 (default): worker threads. The asset's
   * bytes are the same either way. */
  int host_on_calling_thread;
  /** Bound on the points spent refining toward an infeasible region, as a fraction of
   * max_samples (default 0.25; >= 0 and finite, or negative for no bound). An element that
   * depends on a point where the host failed is split toward the feasibility boundary (along the
   * direction separating its feasible from its infeasible samples), so that the runtime refuses
   * little more than the region where the host truly fails; an element whose samples and centre
   * all fail is never split (its children would keep a failing corner). Each refinement wave
   * splits these elements first, largest first, and their children that still depend on a failed
   * point at once, before any element above tolerance: when the budget ends, the feasible space
   * has been kept first (a refused element answers nothing; one above tolerance answers, with an
   * error its estimate reports). Once ceil(infeasible_call_fraction x max_samples) points have
   * failed, no element is split any
   * more for being infeasible (elements above tolerance still are); the splits already decided
   * still evaluate their points, so the failures can exceed the bound by one refinement wave's
   * points. 0: infeasible elements are never split. Failures are counted by point (host or
   * sample store alike), so a resumed build decides as the first did. Builds of hosts that
   * never fail do not depend on it. */
  double infeasible_call_fraction;
  /** Which face centres of an element the refinement test asks the host for (paper §4.2 tests
   * an element at its centre; the builder adds its 2K face centres, which catch ridge-like
   * errors the centre misses). 0 (default): all of them, for every element tested. Nonzero:
   * lazily, for budget-bound builds whose cost is their host calls: an element is tested at its
   * centre and at the face centres already answered, and only if it passes there at the others
   * (it is kept only if it passes at all 2K, as with 0); a failing element's split direction is
   * estimated from points already answered on lines through its centre, else inherited from its
   * parent, and probed only where neither exists. Measured on the analytic bracket, plate and
   * foldplate at a 400-sample budget: 1.7-1.9 host calls per kept sample instead of 2.8-3.5, at
   * the same error (src/core/README.md); on builds that reach the tolerances the estimated
   * directions can cost accuracy, so it is off by default. Recorded in the asset's provenance
   * when nonzero. */
  int lazy_face_centres;
  /** Memory for the builder's cache of mapped samples, in bytes: each element's terms mapped
   * onto its canonical mesh (paper §6), kept from the refinement's tests for the element stage,
   * which needs the same maps. Once it is full the least recently used maps are dropped and
   * mapped again when needed (cadinterp_build_stages.maps_again counts them), which costs time
   * only: the asset's bytes do not depend on it. 0 (default): a quarter of the machine's physical
   * memory, no less than 512 MiB (512 MiB where it cannot be read). A map takes 8 bytes per
   * vertex coordinate and per vertex field component (a 4,400-vertex mesh with 7 field
   * components: about 350 kB). */
  uint64_t map_cache_bytes;
  /** Random points (0..CADINTERP_MAX_CALIBRATION_POINTS; default 0: none) where the builder
   * asks the host, besides its samples, to calibrate the error estimates on points no element is
   * built from. At each point that falls in a feasible element and where the host answers, the
   * meshes the element stores, blended there, are measured against the host's answer as an
   * asset is checked against its host (geometry: symmetric Hausdorff distance relative to the
   * diagonal; each field relative to its range, against the host's field located at the blended
   * vertices where the meshes differ). Per quantity, cadinterp_error_estimates keeps the
   * built-in safety factor unless these points show, with 95 % confidence, that it bounds the
   * error at fewer than 90 % of the asset's points, or that a smaller factor bounds 90 %. Where
   * it overstates, every element's model of that quantity is multiplied by the factor that
   * bounds 90 % with 95 % confidence (an order statistic of the points' least sufficient
   * factors: of 40 measured points the largest, of 60 the second largest), but never so little
   * that an estimate falls below the errors the builder measured on its elements. Where it
   * falls short, the builder either multiplies the model so, or adds to every element's floor
   * of the quantity the floor that bounds 90 % with that confidence (the same order statistic
   * of the points' least sufficient floors), whichever makes the points' estimates the smaller
   * multiple of their errors at the median: the floor serves errors that do not vanish next to
   * the samples (a field carried on its sample's mesh against the host's mesh at x). Fewer than
   * 29 measured points change nothing (cadinterp_build_stages.calibration and
   * calibration_floors have the factors and floors). The points come from a fixed seed, so a
   * sample store answers them on a later run; they count as host evaluations (or store hits)
   * and infeasible points like any other, not as samples. Recorded in the asset's provenance
   * when nonzero. */
  int calibration_points;
} cadinterp_build_options;

/** Fills `options` with the defaults above (struct_size included; other bytes zero). NULL is a
 * no-op. Thread-safe. */
CADINTERP_API void cadinterp_build_options_init(cadinterp_build_options* options);

/** Counts and times of a run (see cadinterp_builder_report). Grows by addition: the caller sets
 * struct_size. */
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
  /** Host evaluations of this run that failed (infeasible or non-finite); infeasible_points
   * also counts failed points read from the sample store. */
  int infeasible_host_evaluations;
} cadinterp_build_report;

/* ---- Building ------------------------------------------------------------------------------
 * A builder is used by one thread at a time: no two calls on the same builder may overlap,
 * and none may be made from its progress callback. Different builders are independent (but two
 * builds sharing one store_path at once are not supported). */

/**
 * Creates a builder for `host` with `options` (NULL: defaults). Both are copied (see
 * cadinterp_host and cadinterp_build_options for what must outlive the builder). The caller
 * owns the new builder and frees it with cadinterp_builder_destroy.
 * @param[out] out the new builder; set to NULL on every failure (when out is not NULL).
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL host or out, or an inconsistent
 *         host or options (a struct_size too small, a value outside its documented range,
 *         simulate_mapped without simulate); CADINTERP_E_OUT_OF_MEMORY; CADINTERP_E_INTERNAL.
 *         The message of a failure is available from cadinterp_builder_create_error().
 * Thread-safety: safe to call from any number of threads at once.
 */
CADINTERP_API cadinterp_status cadinterp_builder_create(const cadinterp_host* host,
                                                        const cadinterp_build_options* options,
                                                        cadinterp_builder** out);
/** Message of the calling thread's last cadinterp_builder_create: why it failed, or "" after a
 * success (never NULL). Thread-local storage, valid until that thread's next create. */
CADINTERP_API const char* cadinterp_builder_create_error(void);
/** Deprecated name of cadinterp_builder_create_error (a create, not an open); same result. Kept
 * exported for one release, then removed. */
CADINTERP_DEPRECATED("use cadinterp_builder_create_error")
CADINTERP_API const char* cadinterp_builder_open_error(void);
/** Destroys a builder and every string it returned (messages, reasons); NULL is a no-op. The
 * host's `user` is not touched. Not concurrently with another call on the same builder. */
CADINTERP_API void cadinterp_builder_destroy(cadinterp_builder* builder);

/**
 * Runs the build and writes the asset to `output_path` (written to a temporary name and
 * renamed, so a killed build never leaves a partial asset under that name). The temporary file
 * is created and removed once before the build starts, so an output that cannot be written (a
 * missing directory, no permission) fails at once with CADINTERP_E_IO, before any host call.
 * May be called again on the same builder: each run starts a fresh report and, with a
 * store_path, reads the samples already stored instead of calling the host again. Blocks until
 * the build ends; host callbacks run on worker threads, the progress callback on this thread.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT (a NULL builder, a NULL or empty path, or
 *         asset content the writer refuses); CADINTERP_E_CANCELLED; CADINTERP_E_IO (store or
 *         output); CADINTERP_E_STORE_MISMATCH (the store belongs to another host, identity or
 *         box); CADINTERP_E_INFEASIBLE (no element could be built: the host failed everywhere,
 *         or no element's samples could be mapped onto its canonical mesh);
 *         CADINTERP_E_OUT_OF_MEMORY; CADINTERP_E_INTERNAL. But for a NULL builder, the message
 *         is available from cadinterp_builder_error, and the report, stages and reasons
 *         describe what the run did before it ended, whatever the outcome.
 */
CADINTERP_API cadinterp_status cadinterp_builder_run(cadinterp_builder* builder,
                                                     const char* output_path);
/** The report of the last run, finished or failed (zeros before the first). After a failure it
 * counts what was done before it: host_evaluations, store_hits, infeasible_points; `samples` is
 * the points requested so far when the refinement did not finish, `elements` the leaves so far.
 * Fills at most out->struct_size bytes (grow-by-addition) and sets out->struct_size to the bytes
 * filled.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT (out untouched, no message) for a NULL
 *         builder or out, or out->struct_size < sizeof(size_t). */
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
  /** The host's message for the first of those failures ("" if none; never NULL); builder-owned,
   * valid until the next run or destroy. */
  const char* first_mapped_simulate_failure;
  /** canonical_refinement: elements whose canonical mesh was refined, and the vertices added to
   * their canonical meshes in all. */
  int refined_elements;
  int refined_vertices;
  /** Refinement toward infeasible regions (cadinterp_build_options::infeasible_call_fraction):
   * elements split because they depend on a failed point; infeasible elements left unsplit
   * because their samples and centre all fail (inside the region); and those left unsplit
   * because the bound on failed points was reached. */
  int infeasible_splits;
  int interior_unsplit;
  int bound_unsplit;
  /** Samples mapped onto another sample's canonical mesh (the mapper's calls through the cache
   * of cadinterp_build_options.map_cache_bytes; canonical refinement's maps onto a refined mesh
   * are not counted), and of those the pairs mapped before, dropped from the full cache and
   * needed again. */
  int maps;
  int maps_again;
  /** Cubic elements built on their corner fallback (their 2^K corners, multilinear) because
   * one of their terms could not be mapped onto their canonical mesh although every sample is
   * feasible. They are usable, so neither unmapped_elements nor the report's
   * infeasible_elements counts them. */
  int unmapped_fallbacks;
  /** calibration_points: the points where the host answered inside a built element and its
   * stored meshes were measured; and per quantity (geometry, then each field in the asset's order)
   * the factor the builder multiplied the error model by, calibration_count values
   * (builder-owned, valid until the next run or destroy; NULL and 0 without calibration). */
  int calibrated_points;
  int calibration_count;
  const double* calibration;
  /** Per quantity (calibration_count values, in calibration's order), the floor the builder
   * added to every element's floor of that quantity, relative as the quantity's estimates: 0
   * where the factor alone served (builder-owned, valid until the next run or destroy; NULL
   * without calibration). */
  const double* calibration_floors;
} cadinterp_build_stages;

/** Stage times and counts of the last run, finished or failed (zeros before the first). Fills
 * at most out->struct_size bytes (grow-by-addition) and sets out->struct_size to the bytes
 * filled.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT (out untouched, no message) for a NULL
 *         builder or out, or out->struct_size < sizeof(size_t). */
CADINTERP_API cadinterp_status cadinterp_builder_stages(const cadinterp_builder* builder,
                                                        cadinterp_build_stages* out);

/** The last run's index-th distinct reason for infeasible points (first met first, at most 8;
 * their number is cadinterp_build_stages.infeasible_reasons): the host's message (builder-owned,
 * valid until the next run or destroy) and how many points gave it. Either output may be NULL.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT (outputs untouched, no message) for a NULL
 *         builder or an index outside 0..infeasible_reasons-1. */
CADINTERP_API cadinterp_status cadinterp_builder_infeasible_reason(const cadinterp_builder* builder,
                                                                   int index, const char** message,
                                                                   int* count);
/** Message of the builder's last run: why it failed, or "" after a success or before the first
 * run; "builder is NULL" for NULL (never NULL). Builder-owned, valid until the next run or
 * destroy. */
CADINTERP_API const char* cadinterp_builder_error(const cadinterp_builder* builder);

/* ---- Build sessions: the host drives the loop -----------------------------------------------
 * A session is a build turned inside out. Instead of calling the host's callbacks, it says which
 * parameter points it needs next (requests) and accepts their samples in any order, from any
 * thread. The host then drives the loop: on its main thread, from an event loop with
 * asynchronous requests to a remote kernel, from worker processes, or from a cluster scheduler.
 * cadinterp_builder_run is itself a driver over a session (threads calling the callbacks), and a
 * session writes the same asset bytes as cadinterp_builder_run for the same host and options.
 *
 *   cadinterp_build_session* s;
 *   cadinterp_build_session_create(builder, &s);
 *   for (;;) {
 *     cadinterp_build_request r[16];
 *     size_t n;
 *     int done;
 *     cadinterp_build_session_next_requests(s, r, 16, -1, &n, &done);
 *     if (done) break;
 *     for (size_t i = 0; i < n; ++i) {
 *       cadinterp_sample* out;
 *       cadinterp_build_session_sample(s, r[i].id, &out);
 *       cadinterp_status st = my_regenerate(my_user, r[i].x, out);   // + references, simulate
 *       cadinterp_build_session_submit(s, r[i].id, st);
 *     }
 *   }
 *   cadinterp_build_session_finish(s, "model.cadi");      // then cadinterp_builder_report(...)
 *   cadinterp_build_session_destroy(s);
 *
 * The session belongs to the builder it was created from: it uses the builder's copied host
 * (name, identity and parameters; its callbacks are never called by a session and may be NULL
 * when only sessions are used), its options and sample store (points already in the store are
 * read, never requested), and its report, stages, reasons and error describe the session's run
 * once it ends (finished, failed or destroyed). While a session exists, the builder accepts no
 * cadinterp_builder_run and no second session (CADINTERP_E_INVALID_ARGUMENT).
 *
 * Progress callback: called on the threads that call cadinterp_build_session_submit (after each
 * accepted sample) and cadinterp_build_session_next_requests, one call at a time (never
 * concurrently with itself), with the build's latest progress when it changed since the last
 * call; a nonzero return cancels the session as cadinterp_build_session_cancel does.
 *
 * The report's host_seconds counts, for each sample answered through a session, the time from
 * its hand-out by next_requests to its submit (the host's own time is not known here; serialized
 * samples do not carry it). cadinterp_builder_run's drivers count the host's own time, as
 * before. */

/** A build in progress driven by the caller (opaque). */
typedef struct cadinterp_build_session cadinterp_build_session;

/** What a request asks for. */
typedef enum cadinterp_request_kind {
  /** The host's sample at x: regenerate, references, then simulate if the host has fields, all
   * written into the request's cadinterp_sample (cadinterp_build_session_sample). */
  CADINTERP_REQUEST_SAMPLE = 1,
  /** With simulate_mapped only: simulate at x on `mesh` (another sample's mesh mapped to x's
   * shape, paper §6), writing fields only; the request's cadinterp_sample carries that mesh. */
  CADINTERP_REQUEST_SIMULATE = 2
} cadinterp_request_kind;

/** One request. Fixed layout (not grown by addition: a new kind of request comes with a new
 * function). The pointers are session-owned and stay valid until the request is submitted, the
 * session is cancelled, or it is destroyed, whichever comes first. */
typedef struct cadinterp_build_request {
  uint64_t id;                     /**< nonzero, unique within the session */
  int kind;                        /**< a cadinterp_request_kind */
  int parameter_count;             /**< K */
  const double* x;                 /**< K values inside the parameter box */
  const cadinterp_host_mesh* mesh; /**< CADINTERP_REQUEST_SIMULATE: the mesh; else NULL */
} cadinterp_build_request;

/**
 * Starts a session on `builder` (see above). The caller owns it and ends it with
 * cadinterp_build_session_destroy, which the builder must outlive. Opens the sample store and
 * starts the refinement at once; the first requests are then available.
 * @param[out] out the session; set to NULL on every failure (when out is not NULL).
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT (NULL builder or out, or a session or run
 *         already active on the builder); CADINTERP_E_IO or CADINTERP_E_STORE_MISMATCH (the
 *         store); CADINTERP_E_OUT_OF_MEMORY; CADINTERP_E_INTERNAL. The message is available from
 *         cadinterp_builder_error(builder).
 * Thread-safety: not concurrently with another call on the same builder.
 */
CADINTERP_API cadinterp_status cadinterp_build_session_create(cadinterp_builder* builder,
                                                              cadinterp_build_session** out);

/**
 * Hands out up to `capacity` requests that were not handed out before (each request exactly
 * once). While there is none to hand out and the build is not done, waits up to timeout_ms
 * milliseconds (0: does not wait; -1: until a request or the end comes) for the refinement to
 * produce some: it produces the next wave only after every request of the current one is
 * submitted, so a driver that answers on the same thread must submit what it was handed before
 * it waits again.
 * @param[out] requests capacity requests (may be NULL when capacity is 0)
 * @param[out] count    the number written, 0..capacity
 * @param[out] done     nonzero when the session will hand out no more requests: the build is
 *                      finished (call cadinterp_build_session_finish), failed or cancelled
 *                      (finish then returns why)
 * @return CADINTERP_OK (also when nothing was handed out); CADINTERP_E_INVALID_ARGUMENT for a
 *         NULL session, count or done, or NULL requests with a nonzero capacity (outputs
 *         untouched).
 * Thread-safety: may be called from any thread, concurrently with the other session functions
 * except destroy.
 */
CADINTERP_API cadinterp_status cadinterp_build_session_next_requests(
    cadinterp_build_session* session, cadinterp_build_request* requests, size_t capacity,
    int timeout_ms, size_t* count, int* done);

/**
 * The builder-owned sample a request's answer is written into, with the cadinterp_sample_*
 * functions, exactly as the host's callbacks write (for CADINTERP_REQUEST_SIMULATE its mesh is
 * already set). Valid until the request is submitted or the session destroyed; one thread at a
 * time per request.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument (outputs untouched);
 *         CADINTERP_E_NOT_FOUND when `id` is not a request handed out and not yet submitted.
 * Thread-safety: any thread; different requests concurrently.
 */
CADINTERP_API cadinterp_status cadinterp_build_session_sample(cadinterp_build_session* session,
                                                              uint64_t id, cadinterp_sample** out);

/**
 * Answers request `id` with its sample as written: host_status CADINTERP_OK hands it to the
 * build, which validates it (an invalid mesh makes the point infeasible, with the builder's
 * message); any other status makes the point infeasible, with the message set by
 * cadinterp_sample_set_message or else the status's name. Answers may come in any order.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL session; CADINTERP_E_NOT_FOUND
 *         when `id` is not a request handed out and not yet submitted; CADINTERP_E_CANCELLED
 *         after the session was cancelled or failed (the answer is dropped);
 *         CADINTERP_E_IO when the sample store cannot be written (the session then fails);
 *         CADINTERP_E_OUT_OF_MEMORY.
 * A CADINTERP_REQUEST_SAMPLE answer returns once the build has taken it and, with a store,
 * stored it (so an OK answer survives a kill). An answer to a request handed out before a cancel
 * is dropped by the build (CADINTERP_E_CANCELLED) but still stored, so that a resumed session
 * does not ask for it again.
 * Thread-safety: any thread; different requests concurrently.
 */
CADINTERP_API cadinterp_status cadinterp_build_session_submit(cadinterp_build_session* session,
                                                              uint64_t id,
                                                              cadinterp_status host_status);

/**
 * Answers request `id` with a sample computed elsewhere (another process, rank or machine):
 * the bytes written there by cadinterp_host_evaluate_serialized (CADINTERP_REQUEST_SAMPLE) or
 * cadinterp_host_simulate_serialized (CADINTERP_REQUEST_SIMULATE) from the same builder
 * version. Copied. Same rules and returns as cadinterp_build_session_submit, plus
 * CADINTERP_E_INVALID_ARGUMENT for NULL bytes or bytes that are not such a sample (the request
 * stays open and may be answered again).
 */
CADINTERP_API cadinterp_status cadinterp_build_session_submit_serialized(
    cadinterp_build_session* session, uint64_t id, const void* bytes, size_t size);

/**
 * Cancels the session: no new request is handed out, answers are dropped, and finish returns
 * CADINTERP_E_CANCELLED. The samples answered so far stay in the store, so a new session on a
 * builder with the same store resumes from them. Idempotent.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for NULL.
 * Thread-safety: any thread, at any time before destroy.
 */
CADINTERP_API cadinterp_status cadinterp_build_session_cancel(cadinterp_build_session* session);

/**
 * Waits until the session is done (see next_requests), then writes the asset to output_path as
 * cadinterp_builder_run does (temporary name, renamed). The builder's report, stages, reasons
 * and error then describe the run.
 * @return the statuses of cadinterp_builder_run (CADINTERP_E_CANCELLED after a cancel);
 *         CADINTERP_E_INVALID_ARGUMENT for a NULL session or path, or a second finish. An empty
 *         path (CADINTERP_E_INVALID_ARGUMENT) or one that cannot be written (CADINTERP_E_IO,
 *         checked before the wait, as cadinterp_builder_run does) leaves the session unfinished:
 *         finish may be called again with another path.
 * Thread-safety: one thread; it blocks while requests are outstanding, so they must be answered
 * by other threads, or before finish is called.
 */
CADINTERP_API cadinterp_status cadinterp_build_session_finish(cadinterp_build_session* session,
                                                              const char* output_path);

/** Ends a session (cancelling it if it is not finished) and frees it; the samples answered so
 * far stay in the store. Requests and samples it handed out become invalid. Waits for the
 * build's own work to stop (at its next request, or at its end when every point is in the
 * store). Unless finished, the builder's report, stages and error then describe the abandoned
 * run (error "build cancelled"). The builder accepts a run or a new session again. NULL is a
 * no-op. Not concurrently with another call on the session. */
CADINTERP_API void cadinterp_build_session_destroy(cadinterp_build_session* session);

/* ---- Evaluating a host elsewhere -------------------------------------------------------------
 * What a worker process or rank runs for a session driver: the host's callbacks at x, guarded
 * and validated exactly as the builder's own threads call them, and the result as bytes for
 * cadinterp_build_session_submit_serialized. A failing host gives bytes too (an infeasible
 * sample with its message): only a crash of the host itself is not covered. */

/**
 * Runs regenerate, references and simulate of `host` at x (K doubles) and serializes the
 * sample. The caller owns *bytes and frees it with cadinterp_bytes_free.
 * @return CADINTERP_OK (also when the host failed at x: the bytes say so);
 *         CADINTERP_E_INVALID_ARGUMENT for a NULL argument or an inconsistent host (as
 *         cadinterp_builder_create would refuse it); CADINTERP_E_OUT_OF_MEMORY.
 * Thread-safety: concurrently for different x when the host is thread_safe; otherwise calls
 * with the same host must not overlap.
 */
CADINTERP_API cadinterp_status cadinterp_host_evaluate_serialized(const cadinterp_host* host,
                                                                  const double* x, void** bytes,
                                                                  size_t* size);
/** As cadinterp_host_evaluate_serialized for a CADINTERP_REQUEST_SIMULATE request: the host's
 * simulate at x on `mesh`. Also CADINTERP_E_INVALID_ARGUMENT for a NULL mesh. */
CADINTERP_API cadinterp_status cadinterp_host_simulate_serialized(const cadinterp_host* host,
                                                                  const double* x,
                                                                  const cadinterp_host_mesh* mesh,
                                                                  void** bytes, size_t* size);
/** Frees bytes returned by the builder (cadinterp_host_*_serialized); NULL is a no-op. */
CADINTERP_API void cadinterp_bytes_free(void* bytes);

#ifdef __cplusplus
}
#endif

#endif /* CADINTERP_BUILDER_H */
