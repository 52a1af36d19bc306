/* cadinterp runtime: open a precomputed asset (.cadi) and evaluate the interpolated shape, its
 * fields and their derivatives at any parameter vector x.
 *
 * C99, frozen ABI 1: grows by addition only (include/README.md, "Stability"). Conventions (apply to
 * every function unless its comment says otherwise):
 * - Every fallible function returns a cadinterp_status; CADINTERP_OK is 0. On failure its outputs
 *   are left untouched. Calls that take a workspace keep a message (cadinterp_workspace_error,
 *   unless the workspace itself is NULL), and so do cadinterp_open* (cadinterp_open_error);
 *   queries that take only an asset keep none: their status says it all.
 * - A NULL asset or workspace, or a NULL pointer where a value is read or written, gives
 *   CADINTERP_E_INVALID_ARGUMENT unless the parameter says "may be NULL"; functions that return a
 *   count return 0 for a NULL asset.
 * - No C++ exception crosses this interface; out-of-memory is reported as a status.
 * - Thread-safety: an opened cadinterp_asset is immutable (but for its internal element cache,
 *   which is synchronized) and may be used by any number of threads at once. A
 *   cadinterp_workspace holds per-thread scratch: one thread at a time per workspace; create one
 *   per thread.
 * - Pointers returned in output structs point into the workspace (valid until the next call with
 *   that workspace or its destruction) or into the asset (valid until cadinterp_close), as stated.
 * - Shapes are written libigl-style: "#V by 3" is a row-major array of #V rows of 3 values.
 * - Integer types: counts and indices of the asset's things (parameters, fields, regions, face
 *   tags of a region, elements, infeasible points; also the number of fields a call requests)
 *   are int; counts and indices of a mesh's vertices, tets and triangles are uint32_t; lengths
 *   of the caller's buffers of mesh ids, and byte sizes, are size_t.
 * - Names: how many of a thing the asset holds is cadinterp_<thing>_count(asset); one of them
 *   is cadinterp_<thing>(asset, i, ...), its struct (if any) cadinterp_<thing>_info; an
 *   evaluation at x is cadinterp_eval or cadinterp_eval_<what>. An old name stays for one
 *   release as a deprecated alias (CADINTERP_DEPRECATED, cadinterp_version.h), declared at the
 *   end of this header.
 */
#ifndef CADINTERP_H
#define CADINTERP_H

#include <stddef.h>
#include <stdint.h>

#include "cadinterp/cadinterp_status.h"
#include "cadinterp/cadinterp_version.h"

/* CADINTERP_API marks the exported functions. Windows: dllexport while libcadinterp.dll is built,
 * dllimport for its users, nothing for a static link (define CADINTERP_STATIC, as the static
 * library's CMake target does for its users). ELF and Mach-O: default visibility, the library
 * being compiled with hidden visibility. */
#if defined(_WIN32) || defined(__CYGWIN__)
#if defined(CADINTERP_STATIC)
#define CADINTERP_API
#elif defined(CADINTERP_BUILDING_LIBRARY)
#define CADINTERP_API __declspec(dllexport)
#else
#define CADINTERP_API __declspec(dllimport)
#endif
#elif defined(__GNUC__) || defined(__clang__)
#define CADINTERP_API __attribute__((visibility("default")))
#else
#define CADINTERP_API
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
/** Asset format version this library implements: major and minor (either pointer may be NULL:
 *  that value is not written). It also reads assets of newer minors of that major, ignoring
 *  what it does not know, unless one lists a required feature it lacks (fileformat/SPEC.md,
 *  "Versions and features"). Thread-safe. */
CADINTERP_API void cadinterp_format_version(int* major, int* minor);
/** Fixed English text of a status (static storage; never NULL; "unknown status" for a value
 *  this library does not define). Thread-safe. */
CADINTERP_API const char* cadinterp_status_string(cadinterp_status status);

/* ---- Opening ------------------------------------------------------------------------------- */

/**
 * Opens the asset file at `path` by memory-mapping it. Only the header and the index are read
 * and verified; meshes are decoded on demand, one element at a time. Cost is independent of the
 * size of the mesh data. The file is mapped, not copied: it must not be changed or truncated
 * while the asset is open.
 * Thread-safe: any number of threads may open assets at once (the message is per thread).
 * @param[in]  path  file name (NUL-terminated)
 * @param[out] out   the asset on success; untouched on failure
 * @return CADINTERP_OK or an error (message: cadinterp_open_error on this thread):
 *         CADINTERP_E_INVALID_ARGUMENT for a NULL argument; CADINTERP_E_IO if the file cannot be
 *         opened or mapped, or is not a regular file (a directory, a FIFO, a device: refused
 *         without reading from it or waiting for a writer); the format errors of the header
 *         and the index (CADINTERP_E_BAD_MAGIC ... CADINTERP_E_LIMIT), among them
 *         CADINTERP_E_UNSUPPORTED_VERSION for another format major or for a required feature
 *         this library does not implement (the message names the feature); an asset of a newer
 *         minor opens otherwise; CADINTERP_E_OUT_OF_MEMORY
 */
CADINTERP_API cadinterp_status cadinterp_open(const char* path, cadinterp_asset** out);

/**
 * Opens an asset held in memory, as cadinterp_open does a file.
 * @param[in]  data  `size` bytes of a .cadi file (not NULL, even when size is 0)
 * @param[in]  copy  nonzero: the bytes are copied; zero: the caller keeps them alive and unchanged
 *                   until cadinterp_close
 * @param[out] out   the asset on success; untouched on failure
 * @return CADINTERP_OK or an error (message: cadinterp_open_error on this thread):
 *         CADINTERP_E_INVALID_ARGUMENT for a NULL argument; the format errors of the header and
 *         the index (CADINTERP_E_BAD_MAGIC ... CADINTERP_E_LIMIT); CADINTERP_E_OUT_OF_MEMORY.
 * Thread-safe, as cadinterp_open.
 */
CADINTERP_API cadinterp_status cadinterp_open_memory(const void* data, size_t size, int copy,
                                                     cadinterp_asset** out);

/** Bit of cadinterp_open_options.flags: verify the checksum of every blob while opening (reads
 *  the whole file once; a corrupt blob fails the open with CADINTERP_E_CHECKSUM), instead of
 *  each blob when an evaluation first decodes it. For assets received from an untrusted or lossy
 *  channel, where a failure at open is easier to handle than one in the middle of evaluations. */
#define CADINTERP_OPEN_VERIFY_BLOBS ((uint64_t)1)
/** Every flag bit this header defines; a library refuses any other bit (see the struct). */
#define CADINTERP_OPEN_KNOWN_FLAGS CADINTERP_OPEN_VERIFY_BLOBS

/**
 * Options of cadinterp_open_with_options and cadinterp_open_memory_with_options. Zero means
 * "default" for every member, so a zero-initialised struct with struct_size set (or
 * cadinterp_open_options_init) opens exactly as cadinterp_open does.
 *
 * Growth by addition (the struct_size rule, as Linux's copy_struct_from_user): members are only
 * ever appended, and a member's zero always means the behaviour without it.
 * - struct_size smaller than the 1.0 struct (CADINTERP_OPEN_OPTIONS_SIZE_1_0 bytes, which every
 *   caller has) is refused with CADINTERP_E_INVALID_ARGUMENT;
 * - a caller compiled against an older header passes a smaller size than the library's struct:
 *   the members beyond it take their zero meaning;
 * - a caller compiled against a newer header passes a larger size: the library reads its own
 *   members and requires every byte beyond them (up to struct_size) to be zero, that is, every
 *   newer member to be left at its default; otherwise CADINTERP_E_INVALID_ARGUMENT, with a message
 *   naming the offset (an option this library cannot honour is refused, never ignored).
 * Members are laid out without padding (flags is 64-bit) on every ABI, so no uninitialised
 * padding byte can be mistaken for a newer member; appended members must keep it so.
 */
typedef struct cadinterp_open_options {
  /** sizeof(cadinterp_open_options) as the caller compiled it. */
  size_t struct_size;
  /** Byte budget of the cache of decoded elements, as cadinterp_set_cache_budget sets it later;
   *  0: the default, 256 MiB. (1 keeps only the most recently used element.) */
  size_t cache_budget_bytes;
  /** CADINTERP_OPEN_* bits; 0: none. A bit outside CADINTERP_OPEN_KNOWN_FLAGS of the linked
   *  library gives CADINTERP_E_INVALID_ARGUMENT, its message naming the bits. */
  uint64_t flags;
} cadinterp_open_options;

/** Bytes of the options struct of library 1.0: the smallest struct_size accepted. */
#define CADINTERP_OPEN_OPTIONS_SIZE_1_0 (2 * sizeof(size_t) + sizeof(uint64_t))

/** Sets *options to the defaults: every member zero and struct_size = sizeof(*options).
 *  NULL is a no-op. Thread-safe. */
CADINTERP_API void cadinterp_open_options_init(cadinterp_open_options* options);

/**
 * cadinterp_open with options. `options` may be NULL: the defaults (exactly cadinterp_open).
 * @param[in]  path     file name (NUL-terminated)
 * @param[in]  options  may be NULL; read only during the call (the caller keeps ownership)
 * @param[out] out      the asset on success; untouched on failure
 * @return as cadinterp_open, and CADINTERP_E_INVALID_ARGUMENT for options that break the
 *         struct_size rule or set an unknown flag bit; with CADINTERP_OPEN_VERIFY_BLOBS also
 *         CADINTERP_E_CHECKSUM for a corrupt blob. Message: cadinterp_open_error on this thread.
 * Thread-safe, as cadinterp_open.
 */
CADINTERP_API cadinterp_status cadinterp_open_with_options(const char* path,
                                                           const cadinterp_open_options* options,
                                                           cadinterp_asset** out);

/**
 * cadinterp_open_memory with options (see cadinterp_open_with_options for `options`).
 * @return as cadinterp_open_memory, and the options' failures of cadinterp_open_with_options.
 * Thread-safe, as cadinterp_open.
 */
CADINTERP_API cadinterp_status
cadinterp_open_memory_with_options(const void* data, size_t size, int copy,
                                   const cadinterp_open_options* options, cadinterp_asset** out);

/** Message of this thread's most recent cadinterp_open* call: its failure's text, or "" after a
 *  success (and before any call), as SQLite's sqlite3_errmsg. Thread-local storage, valid until
 *  the next cadinterp_open* call on this thread. Thread-safe (never NULL). */
CADINTERP_API const char* cadinterp_open_error(void);

/** Closes an asset and frees it; NULL is a no-op. Every workspace of the asset must be destroyed
 *  first, and no other call may use the asset concurrently or afterwards: every string and array
 *  the asset returned becomes invalid. */
CADINTERP_API void cadinterp_close(cadinterp_asset* asset);

/* ---- Queries ---------------------------------------------------------------------------------
 * Every query is thread-safe (it reads the immutable index, or the synchronized cache), writes
 * its outputs only on success, and returns strings and arrays owned by the asset, valid until
 * cadinterp_close. */

/** Number of parameters K (1..8), or 0 if asset is NULL. Thread-safe. */
CADINTERP_API int cadinterp_parameter_count(const cadinterp_asset* asset);
/** Basis degree: 1 (linear, C0) or 3 (cubic, C2), 0 if asset is NULL. */
CADINTERP_API int cadinterp_degree(const cadinterp_asset* asset);
/** Number of elements of the K-d tree, 0 if asset is NULL. */
CADINTERP_API int cadinterp_element_count(const cadinterp_asset* asset);
/** Format version of this asset's file: major and minor, both required (unlike
 *  cadinterp_format_version); CADINTERP_E_INVALID_ARGUMENT if any argument is NULL. */
CADINTERP_API cadinterp_status cadinterp_asset_format(const cadinterp_asset* asset, int* major,
                                                      int* minor);

typedef struct cadinterp_parameter_info {
  const char* name;
  const char* unit;
  double lower, upper; /**< the parameter's range */
} cadinterp_parameter_info;

/** Parameter i (0 <= i < K): name and unit ("" if none) owned by the asset, and its range.
 *  CADINTERP_E_INVALID_ARGUMENT for a NULL argument or i out of range. */
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
/** Field i (0 <= i < field count); the name is owned by the asset. CADINTERP_E_INVALID_ARGUMENT
 *  for a NULL argument or i out of range. */
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
/** Index of the field called `name` (exact, case-sensitive match). CADINTERP_E_NOT_FOUND if
 *  there is none, CADINTERP_E_INVALID_ARGUMENT for a NULL argument; `*index` untouched on
 *  failure. */
CADINTERP_API cadinterp_status cadinterp_find_field(const cadinterp_asset* asset, const char* name,
                                                    int* index);

typedef struct cadinterp_region_info {
  const char* name;
  const char* kind;         /**< "fixed", "force", "heat", ... as the builder's host named it */
  const int32_t* face_tags; /**< the triangle tags the region covers */
  int face_tag_count;
} cadinterp_region_info;

/** Number of boundary-condition regions (0 if asset is NULL). */
CADINTERP_API int cadinterp_region_count(const cadinterp_asset* asset);
/**
 * Region i (0 <= i < cadinterp_region_count(asset)). Its name, kind ("" if the host gave none)
 * and face tags are owned by the asset, valid until cadinterp_close; face_tags may be NULL when
 * face_tag_count is 0.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument or i out of range
 *         (`*out` untouched). Thread-safety: safe.
 */
CADINTERP_API cadinterp_status cadinterp_region(const cadinterp_asset* asset, int i,
                                                cadinterp_region_info* out);

typedef struct cadinterp_provenance {
  const char* builder_version;
  const char* host;
  const char* options; /**< the build options, JSON */
} cadinterp_provenance;

/**
 * How the asset was built, as the builder recorded it: three NUL-terminated strings owned by the
 * asset, valid until cadinterp_close ("" for any the asset does not record). Named after the
 * asset, as cadinterp_asset_format: the name cadinterp_provenance is its struct's.
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL argument (`*out` untouched).
 * Thread-safety: safe.
 */
CADINTERP_API cadinterp_status cadinterp_asset_provenance(const cadinterp_asset* asset,
                                                          cadinterp_provenance* out);

/**
 * The element holding x, and whether it can be evaluated. Points on faces between elements are
 * assigned deterministically (to the upper side).
 * @param[in]  x        K values
 * @param[out] element  element index (required: NULL gives CADINTERP_E_INVALID_ARGUMENT)
 * @param[out] feasible 1 if eval at x succeeds, 0 if x is in an infeasible element (may be NULL)
 * @return CADINTERP_OK; CADINTERP_E_OUTSIDE_DOMAIN if x is outside the box or not finite;
 *         CADINTERP_E_INVALID_ARGUMENT for a NULL asset, x or element. Outputs untouched on
 *         failure. Thread-safety: safe.
 */
CADINTERP_API cadinterp_status cadinterp_locate(const cadinterp_asset* asset, const double* x,
                                                int* element, int* feasible);

/**
 * The mesh sizes of element `element` (as cadinterp_locate returns it), read from the index
 * without decoding anything: the #V, #T and #F that cadinterp_eval, cadinterp_eval_subset and
 * cadinterp_grad report for any x in the element. For sizing per-vertex and per-tet arrays
 * before a call, notably cadinterp_grad's dfields (cadinterp_mesh_grad has no tet count). An
 * infeasible element has no meshes: all three are 0.
 * @param[in]  element         0 <= element < cadinterp_element_count(asset)
 * @param[out] vertex_count    #V (may be NULL)
 * @param[out] tet_count       #T (may be NULL)
 * @param[out] triangle_count  #F (may be NULL)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT if asset is NULL or element is out of range
 *         (outputs untouched). Thread-safety: safe (reads the immutable index).
 */
CADINTERP_API cadinterp_status cadinterp_element_mesh_size(const cadinterp_asset* asset,
                                                           int element, uint32_t* vertex_count,
                                                           uint32_t* tet_count,
                                                           uint32_t* triangle_count);

/**
 * The number of terms of element `element` (as cadinterp_locate returns it): the samples whose
 * basis functions the element blends (paper eq. 4), so one cadinterp_eval or cadinterp_grad in
 * it reads that many stored meshes (terms x (#V x 3 positions + #V values per scalar field)
 * floats). Read from the index without decoding anything. An infeasible element still reports
 * its terms (it stores no meshes).
 * @param[in]  element  0 <= element < cadinterp_element_count(asset)
 * @param[out] terms    the count (required)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT if asset or terms is NULL or element is out
 *         of range (`*terms` untouched). Thread-safety: safe (reads the immutable index).
 */
CADINTERP_API cadinterp_status cadinterp_element_term_count(const cadinterp_asset* asset,
                                                            int element, int* terms);

/**
 * The estimated geometric error at x: the symmetric Hausdorff distance between the boundary
 * surface cadinterp_eval returns and the host's own at x, relative to the bounding-box diagonal
 * of the host's mesh at x. It is cadinterp_error_estimates' out[0]; see there for how it is
 * estimated and how well it bounds the true error. Assets written before format 1.3 (or
 * without the builder's error model) answer the builder's stored value of the element holding
 * x instead: the largest refinement error measured on it times the geometry tolerance, which
 * on assets with fields was the field error rescaled, not a geometric error.
 * @param[in]  x      K parameter values
 * @param[out] error  the estimate; negative if the builder did not measure it
 * @return CADINTERP_OK; CADINTERP_E_OUTSIDE_DOMAIN as cadinterp_locate; CADINTERP_E_INFEASIBLE
 *         if x lies in an infeasible element (no mesh to be wrong about);
 *         CADINTERP_E_INVALID_ARGUMENT for a NULL argument. `*error` untouched on failure.
 *         Thread-safety: safe (reads the immutable index).
 */
CADINTERP_API cadinterp_status cadinterp_error_estimate(const cadinterp_asset* asset,
                                                        const double* x, double* error);

/**
 * Estimated errors of cadinterp_eval at x, per quantity, against the host's own answer at x:
 * out[0] geometry (symmetric Hausdorff distance of the boundary surfaces relative to the
 * bounding-box diagonal of the host's mesh at x), out[1 + f] field f (largest absolute error
 * of a value relative to the range of field f over the host's mesh at x), in field order.
 * Estimated from the errors the builder measured on the element holding x (at its centre and,
 * per direction, at its face centres; fileformat/SPEC.md "Error model"): on linear assets
 * shaped as multilinear interpolation errs, in 4 t_d (1 - t_d) at x's place t in the element,
 * equal to the measured error at its centre and zero at the samples; on cubic assets the
 * largest measured error, constant over the element. The geometry's adds the element's error
 * at its own samples, where a mapped sample's stored mesh and the host's own mesh of it cut
 * the same surface with other triangles (on a cubic element it is at least that error: the
 * largest measured error already holds it). Each field's adds the element's floor for it where
 * the element's samples were meshed apart and mapped: two meshes of one solid give a field
 * values that differ as much next to a sample as between samples. Calibrated on held-out
 * random points of analytic and OpenCASCADE hosts to bound the true error at about 90 % of
 * points (docs/error-estimates.md gives the measured coverage and the median ratio to the true
 * error per model, and where it falls short). The fields' do not include the float storage
 * error (cadinterp_field's max_abs_error).
 * Assets without the builder's error model (written before format 1.3) report every entry as
 * -1 (unknown).
 * @param[in]  x         K parameter values
 * @param[out] out       capacity doubles; entries: the estimate, or -1 where not measured
 * @param[in]  capacity  number of doubles out can hold; must be >= 1 + cadinterp_field_count
 * @param[out] count     1 + cadinterp_field_count(asset), set whenever asset and count are
 *                       non-NULL, even on failure (so a first call with capacity 0 sizes out)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL asset, x or count, out NULL with
 *         capacity > 0, or capacity < *count; CADINTERP_E_OUTSIDE_DOMAIN as cadinterp_locate;
 *         CADINTERP_E_INFEASIBLE if x lies in an infeasible element. `out` untouched on
 *         failure. Thread-safety: safe (reads the immutable index).
 */
CADINTERP_API cadinterp_status cadinterp_error_estimates(const cadinterp_asset* asset,
                                                         const double* x, double* out, int capacity,
                                                         int* count);

/** Number of parameter points where the builder's host failed (0 if asset is NULL). */
CADINTERP_API int cadinterp_infeasible_point_count(const cadinterp_asset* asset);
/**
 * Infeasible point i (0 <= i < count) as the builder recorded it.
 * @param[out] x        K doubles, real parameter coordinates
 * @param[out] message  the host's message (may be NULL; valid until cadinterp_close)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL asset or x, or i out of range
 *         (outputs untouched). Thread-safety: safe.
 */
CADINTERP_API cadinterp_status cadinterp_infeasible_point(const cadinterp_asset* asset, int i,
                                                          double* x, const char** message);

/**
 * Sets the byte budget of the cache of decoded elements (default 256 MiB). Least recently used
 * elements are dropped beyond it; an element in use by a workspace stays alive until released.
 * A topology shared by several elements counts once; an element's field arrays are decoded (and
 * counted) on the first call that reads fields; the buffers of one dropped element may be kept
 * outside the budget for reuse by the next decode. The cache always keeps the most recently
 * used element, whatever the budget: 0 means "only that one" (every switch to another element
 * decodes again), not "no limit".
 * @return CADINTERP_OK (the new budget applies at once: elements beyond it are dropped);
 *         CADINTERP_E_INVALID_ARGUMENT if asset is NULL.
 * Thread-safety: safe, also while other threads evaluate with workspaces of the asset (the cache
 * is synchronized). The budget lasts until the next call or cadinterp_close.
 */
CADINTERP_API cadinterp_status cadinterp_set_cache_budget(cadinterp_asset* asset, size_t bytes);

/* ---- Evaluation ------------------------------------------------------------------------------
 * One thread at a time per workspace; any number of workspaces of one asset may evaluate at
 * once. Each call sets the workspace's message (cadinterp_workspace_error): "" on success. The
 * decoding errors of an element (CADINTERP_E_CHECKSUM, CADINTERP_E_CORRUPT_BLOB) are reported by
 * every call that needs the data that fails: an element's field arrays are decoded apart from
 * its shape, so a bad field array fails only the calls that read fields. A result that is not
 * finite (the asset's values overflow single precision when blended) is refused with
 * CADINTERP_E_CORRUPT_BLOB rather than handed out. */

/** Creates a workspace for `asset` (which must outlive it). `*out` is owned by the caller: free
 *  it with cadinterp_workspace_destroy. CADINTERP_E_INVALID_ARGUMENT for a NULL argument,
 *  CADINTERP_E_OUT_OF_MEMORY; `*out` untouched on failure. Thread-safe (the asset may be in use
 *  by other threads). */
CADINTERP_API cadinterp_status cadinterp_workspace_create(const cadinterp_asset* asset,
                                                          cadinterp_workspace** out);
/** Destroys a workspace; NULL is a no-op. Not concurrently with another call using it; every
 *  pointer it returned (meshes, gradients, its message) becomes invalid. */
CADINTERP_API void cadinterp_workspace_destroy(cadinterp_workspace* ws);
/** Message of the most recent call made with `ws`: its failure's text, or "" if it succeeded
 *  (and before any call), as SQLite's sqlite3_errmsg; "" for a NULL ws. Owned by the workspace,
 *  valid until the next call with it or its destruction. Never NULL. Same thread rule as the
 *  other calls on the workspace. */
CADINTERP_API const char* cadinterp_workspace_error(const cadinterp_workspace* ws);

/** An evaluated mesh. Every pointer is owned by the workspace: the topology through its
 *  reference to the element, the positions and fields in its scratch; all are valid until the
 *  next call with the workspace or its destruction (copy what must outlive them). */
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
 * @param[in]  fields       indices of the fields to evaluate, in any order, repeats allowed
 *                          (may be NULL if field_count is 0)
 * @param[out] out          the mesh; untouched on failure. Its arrays are owned by the workspace
 *                          (see cadinterp_mesh)
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL ws (no message), out or x, a
 *         negative field_count, NULL fields with a nonzero count, or a field index out of range;
 *         CADINTERP_E_OUTSIDE_DOMAIN if x is outside the box or not finite;
 *         CADINTERP_E_INFEASIBLE if x lies in an infeasible element (cadinterp_locate tells);
 *         the decoding and overflow errors of the section comment; CADINTERP_E_OUT_OF_MEMORY.
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
 * The ids are checked against the element holding x: its #V and #T, which
 * cadinterp_element_mesh_size gives for the element cadinterp_locate returns.
 * @param[in]  vertices  vertex ids (may be NULL if vertex_subset_count is 0)
 * @param[in]  tets      tet ids (may be NULL if tet_subset_count is 0)
 * @return as cadinterp_eval; CADINTERP_E_INVALID_ARGUMENT for a NULL array with a nonzero count
 *         and for an id >= #V (or #T) of the element holding x (the message names the first)
 */
CADINTERP_API cadinterp_status cadinterp_eval_subset(cadinterp_workspace* ws, const double* x,
                                                     const uint32_t* vertices,
                                                     size_t vertex_subset_count,
                                                     const uint32_t* tets, size_t tet_subset_count,
                                                     const int* fields, int field_count,
                                                     cadinterp_mesh* out);

/** Derivatives of an evaluated mesh with respect to the parameters (Eq. 13). It carries no
 *  tet count: per-tet arrays are sized with cadinterp_element_mesh_size (g.element). */
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
 * x, in one pass over the stored samples. Cubic assets are C2 in x. Linear assets are only C0:
 * the derivative is not constant inside an element (each psi_k is a sum of linear B-splines of
 * several levels, paper §4.2, and the finer ones have kinks inside the element) and jumps at
 * every kink and at faces between elements;
 * at a kink this returns one of the one-sided derivatives, on a face between elements that of
 * the element holding x (cadinterp_locate).
 * @param[in]  fields  as cadinterp_eval
 * @param[out] out     untouched on failure; its arrays are owned by the workspace, valid until
 *                     the next call with it. Per-tet field derivatives have K * #T * components
 *                     values: #T from cadinterp_element_mesh_size(asset, out->element, ...).
 * @return as cadinterp_eval.
 */
CADINTERP_API cadinterp_status cadinterp_grad(cadinterp_workspace* ws, const double* x,
                                              const int* fields, int field_count,
                                              cadinterp_mesh_grad* out);

/**
 * Vector-Jacobian product for optimizers: given dF/dP (#V by 3, the adjoint of the positions of
 * the mesh eval returns at x) and optionally the adjoints of requested fields, returns
 * dF/dx (K values) without forming the K derivative arrays.
 * @param[in]  dF_dpositions  #V by 3 for the element holding x (may be NULL: zero)
 * @param[in]  fields         as cadinterp_eval (checked even when dF_dfields is NULL)
 * @param[in]  dF_dfields     field_count pointers: per requested field, its adjoint laid out as
 *                            cadinterp_eval returns that field, or NULL (zero). May itself be
 *                            NULL: no field adjoints (the field arrays are then not decoded)
 * @param[out] dF_dx          K values; untouched on failure
 * @return as cadinterp_eval (CADINTERP_E_INVALID_ARGUMENT also for a NULL dF_dx). The adjoint
 *         arrays are read, not checked: sizes follow the element holding x
 *         (cadinterp_element_mesh_size).
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
 * Centroid and inertia are NaN for a mesh of zero volume (they divide by it); the other members
 * are finite on success.
 * @param[in]  density    uniform density for mass and inertia (finite; any sign)
 * @param[in]  direction  3 finite values, the direction for the frontal area; used as given: a
 *                        non-unit direction scales the frontal area by its length
 * @param[out] out        the quantities; untouched on failure
 * @param[out] grad       NULL, or K structs: grad[d] holds the derivatives along x_d; untouched
 *                        on failure
 * @return as cadinterp_eval; CADINTERP_E_INVALID_ARGUMENT also for a NULL out or direction, or a
 *         density or direction value that is NaN or infinite (checked before x).
 */
CADINTERP_API cadinterp_status cadinterp_eval_properties(cadinterp_workspace* ws, const double* x,
                                                         double density, const double* direction,
                                                         cadinterp_properties* out,
                                                         cadinterp_properties* grad);

/**
 * The integral of one component of a field over the interpolated solid at x, or over one
 * boundary region of it, and optionally its derivatives with respect to x (for objectives such
 * as the paper's integral of von Mises stress, §7.2):
 * - region -1: sum over tets of vol_T * f_T, where f_T is the mean of the tet's 4 vertex values
 *   (a per-vertex field, integrated exactly as the piecewise-linear field it is on the mesh) or
 *   the tet's value (a per-tet field, constant per tet);
 * - region r (0 <= r < cadinterp_region_count): sum over the boundary triangles whose tag is one
 *   of the region's face tags of area_F * f_F, where f_F is the mean of the 3 vertex values or
 *   the value of the tet the triangle bounds.
 * With field -1 the integrand is 1: the volume of the mesh, or the area of the region.
 * Volumes are signed (positively oriented tets are positive), as cadinterp_eval_properties'.
 * Sums are taken in double over the float mesh cadinterp_eval returns at x. The derivatives are
 * exact for the mesh: dI/dx = sum_t dpsi_t/dx (<dI/dP, P_t> + <dI/df, f_t>) (Eq. 13), with the
 * same smoothness as cadinterp_grad (cubic assets C2, linear assets C0 with kinks; the one-sided
 * derivative of the element holding x).
 * @param[in]  x          K parameter values
 * @param[in]  field      a field index, or -1 for the integrand 1
 * @param[in]  component  0 <= component < the field's components (0 when field is -1)
 * @param[in]  region     a region index, or -1 for the volume
 * @param[out] value      the integral; untouched on failure
 * @param[out] grad       NULL, or K values: dI/dx_k; untouched on failure
 * @return as cadinterp_eval; CADINTERP_E_INVALID_ARGUMENT also for a NULL value, a field,
 *         component or region index out of range (the message names which);
 *         CADINTERP_E_CORRUPT_BLOB also when a region triangle bounds no tet (a per-tet field
 *         over a region needs its owner). Thread-safety: as every call on a workspace.
 */
CADINTERP_API cadinterp_status cadinterp_eval_integral(cadinterp_workspace* ws, const double* x,
                                                       int field, int component, int region,
                                                       double* value, double* grad);

/* ---- Per-sample scalar outputs -------------------------------------------------------------
 * Quantities the builder's host computed exactly on each sample (a B-rep volume, a compliance, a
 * maximum stress: cadinterp_sample_add_output), stored per sample (format 1.3) and interpolated
 * with the same basis weights as the mesh: o(x) = sum_t psi_t(x) o_t over the terms t of the
 * element holding x (paper Eq. 3 applied to a scalar). No mesh is decoded or blended, so an
 * evaluation costs O(terms), and no mapping error enters. Assets of format 1.0 to 1.2 have none. */

/** Number of scalar outputs (0 for a NULL asset or an asset without outputs). */
CADINTERP_API int cadinterp_output_count(const cadinterp_asset* asset);

/**
 * Name and unit of output i.
 * @param[in]  i     0 <= i < cadinterp_output_count(asset)
 * @param[out] name  NUL-terminated UTF-8 owned by the asset, valid until cadinterp_close
 * @param[out] unit  NULL, or receives the unit as free text ("" when the host gave none), owned
 *                   by the asset
 * @return CADINTERP_OK; CADINTERP_E_INVALID_ARGUMENT for a NULL asset or name, or i out of range
 * (outputs untouched). Thread-safety: safe (the asset is immutable).
 */
CADINTERP_API cadinterp_status cadinterp_output(const cadinterp_asset* asset, int i,
                                                const char** name, const char** unit);

/** Index of the output called `name` (exact, case-sensitive). CADINTERP_E_NOT_FOUND if there is
 *  none, CADINTERP_E_INVALID_ARGUMENT for a NULL argument; `*index` untouched on failure.
 *  Thread-safety: safe. */
CADINTERP_API cadinterp_status cadinterp_find_output(const cadinterp_asset* asset, const char* name,
                                                     int* index);

/**
 * Interpolated outputs at x, and optionally their exact gradients:
 * values[i] = sum_t psi_t(x) o_t and grad[i * K + d] = sum_t dpsi_t/dx_d o_t, in double, with the
 * smoothness of the basis (cubic assets C2, linear assets C0 with kinks; the one-sided derivative
 * of the element holding x, as cadinterp_grad). Does not decode or touch any element mesh.
 * @param[in]  x             K parameter values
 * @param[in]  outputs       output_count indices (0 <= outputs[i] < cadinterp_output_count);
 *                           may be NULL when output_count is 0
 * @param[out] values        output_count doubles; untouched on failure
 * @param[out] grad          NULL, or output_count by K doubles (row i: d values[i] / dx);
 *                           untouched on failure
 * @return as cadinterp_eval (CADINTERP_E_OUTSIDE_DOMAIN, CADINTERP_E_INFEASIBLE, ...);
 *         CADINTERP_E_INVALID_ARGUMENT also for a NULL x or values, a negative output_count,
 *         NULL outputs with a positive count, or an index out of range (the message says which).
 *         Thread-safety: as every call on a workspace (one thread at a time per workspace).
 */
CADINTERP_API cadinterp_status cadinterp_eval_outputs(cadinterp_workspace* ws, const double* x,
                                                      const int* outputs, int output_count,
                                                      double* values, double* grad);

/* ---- Deprecated names ------------------------------------------------------------------------
 * Each calls its new name and returns what it returns (same thread-safety, ownership and
 * failures). Names of library 0.1 (deprecated since 1.0): exported by every 1.x library, since
 * removing an exported name breaks the frozen ABI 1 (CHANGELOG.md); new code uses the new names. */

/** Deprecated name of cadinterp_parameter_count. */
CADINTERP_DEPRECATED("use cadinterp_parameter_count")
CADINTERP_API int cadinterp_dim(const cadinterp_asset* asset);
/** Deprecated name of cadinterp_asset_provenance. */
CADINTERP_DEPRECATED("use cadinterp_asset_provenance")
CADINTERP_API cadinterp_status cadinterp_get_provenance(const cadinterp_asset* asset,
                                                        cadinterp_provenance* out);
/** Deprecated name of cadinterp_eval_properties. */
CADINTERP_DEPRECATED("use cadinterp_eval_properties")
CADINTERP_API cadinterp_status cadinterp_properties_eval(cadinterp_workspace* ws, const double* x,
                                                         double density, const double* direction,
                                                         cadinterp_properties* out,
                                                         cadinterp_properties* grad);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* CADINTERP_H */
