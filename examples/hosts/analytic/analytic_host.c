/* The host: cadinterp_host callbacks as thin wrappers of the analytic_model_* functions, and the
 * exported entry point.
 *
 * The callbacks only read their immutable model (but for kill_after's atomic call count) and work
 * on memory of their own, so the host is thread-safe. The one global is the list of hosts the entry
 * has handed out: the header promises a host stays valid until the library is unloaded, so the
 * library owns it; equal requests share a host, which bounds the list by the number of distinct
 * (model, options) asked for. */
#define _POSIX_C_SOURCE 200809L

#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "analytic_internal.h"

static cadinterp_status fail(cadinterp_sample* out, cadinterp_status status, const char* message) {
  if (message) cadinterp_sample_set_message(out, message);
  return status;
}

/* The run-time options: kill_after stands in for a kernel that crashes its process, sleep_ms for
 * the minutes a real CAD regeneration and FEM solve take (distributed builds are measured with
 * it, docs/distributed-builds.md). */
static void run_time_behaviour(analytic_model* model) {
  if (model->kill_after >= 0 &&
      __atomic_add_fetch(&model->regenerations, 1, __ATOMIC_RELAXED) > model->kill_after)
    raise(SIGKILL);
  if (model->sleep_ms > 0) {
    struct timespec t;
    t.tv_sec = model->sleep_ms / 1000;
    t.tv_nsec = (model->sleep_ms % 1000) * 1000000L;
    while (nanosleep(&t, &t) != 0) {
    }
  }
}

static cadinterp_status host_regenerate(void* user, const double* x, cadinterp_sample* out) {
  analytic_mesh mesh;
  const char* message = NULL;
  cadinterp_status status;
  run_time_behaviour((analytic_model*)user);
  status = analytic_model_mesh((const analytic_model*)user, x, &mesh, &message);
  if (status != CADINTERP_OK) return fail(out, status, message);
  status =
      cadinterp_sample_set_mesh(out, mesh.vertices, mesh.vertex_count, mesh.tets, mesh.tet_count,
                                mesh.triangles, mesh.triangle_tags, mesh.triangle_count);
  analytic_mesh_free(&mesh);
  return status;
}

static cadinterp_status host_references(void* user, const double* x, cadinterp_sample* out) {
  const analytic_model* model = (const analytic_model*)user;
  analytic_references r;
  const char* message = NULL;
  size_t i;
  int k;
  cadinterp_status status = analytic_model_references(model, x, &r, &message);
  if (status != CADINTERP_OK) return fail(out, status, message);
  for (i = 0; i < r.point_count && status == CADINTERP_OK; ++i)
    status = cadinterp_sample_add_point(out, &r.point_ids[r.point_id_offsets[i]],
                                        r.point_id_offsets[i + 1] - r.point_id_offsets[i],
                                        &r.point_positions[3 * i]);
  for (i = 0; i < r.path_count && status == CADINTERP_OK; ++i) {
    const size_t a = r.path_points[2 * i], b = r.path_points[2 * i + 1];
    status = cadinterp_sample_add_path(
        out, &r.point_ids[r.point_id_offsets[a]], r.point_id_offsets[a + 1] - r.point_id_offsets[a],
        &r.point_ids[r.point_id_offsets[b]], r.point_id_offsets[b + 1] - r.point_id_offsets[b],
        &r.path_vertices[3 * r.path_offsets[i]], r.path_offsets[i + 1] - r.path_offsets[i]);
  }
  for (k = 0; k < analytic_model_region_count(model) && status == CADINTERP_OK; ++k) {
    const analytic_region* region = analytic_model_region(model, k);
    status = cadinterp_sample_add_region(out, region->name, region->kind, region->face_tags,
                                         region->face_tag_count);
  }
  analytic_references_free(&r);
  /* A per-sample scalar output in closed form: the bracket's exact volume, which the
   * interpolated mesh approximates (chords of the bend) and cadinterp_eval_outputs interpolates. */
  if (status == CADINTERP_OK && model->kind == ANALYTIC_BRACKET)
    status = cadinterp_sample_add_output(out, "exact_volume", analytic_bracket_volume(x), "mm^3");
  return status;
}

static cadinterp_status host_simulate(void* user, const double* x, const cadinterp_host_mesh* mesh,
                                      cadinterp_sample* out) {
  const analytic_model* model = (const analytic_model*)user;
  int f;
  for (f = 0; f < analytic_model_field_count(model); ++f) {
    const analytic_field_desc* desc = analytic_model_field(model, f);
    const size_t rows =
        desc->location == CADINTERP_PER_VERTEX ? mesh->vertex_count : mesh->tet_count;
    double* values = (double*)malloc((rows ? rows : 1) * (size_t)desc->components * sizeof(double));
    const char* message = NULL;
    cadinterp_status status;
    if (!values) return fail(out, CADINTERP_E_OUT_OF_MEMORY, "analytic host: out of memory");
    status = analytic_model_field_values(model, f, x, mesh, values, &message);
    if (status == CADINTERP_OK)
      status = cadinterp_sample_add_field(out, desc->name, desc->location, desc->components, values,
                                          rows);
    free(values);
    if (status != CADINTERP_OK) return fail(out, status, message);
  }
  return CADINTERP_OK;
}

/* ---- the hosts handed out ---- */

typedef struct host_record {
  cadinterp_host host;
  analytic_model* model;
  struct host_record* next;
} host_record;

static pthread_mutex_t g_hosts_lock = PTHREAD_MUTEX_INITIALIZER;
static host_record* g_hosts = NULL;

const analytic_model* analytic_host_model(const cadinterp_host* host) {
  return host && host->regenerate == host_regenerate ? (const analytic_model*)host->user : NULL;
}

const cadinterp_host* cadinterp_host_entry(const char* model, const char* options,
                                           const char** error) {
  const char* message = NULL;
  analytic_model* m = analytic_model_create(model, options, &message);
  host_record* r;
  if (!m) {
    if (error) *error = message;
    return NULL;
  }
  pthread_mutex_lock(&g_hosts_lock);
  for (r = g_hosts; r; r = r->next)
    if (strcmp(analytic_model_identity(r->model), analytic_model_identity(m)) == 0 &&
        r->model->sleep_ms == m->sleep_ms && r->model->kill_after == m->kill_after)
      break;
  if (!r && (r = (host_record*)calloc(1, sizeof(*r))) != NULL) {
    r->model = m;
    m = NULL;
    r->host.struct_size = sizeof(cadinterp_host);
    r->host.name = "analytic";
    r->host.identity = analytic_model_identity(r->model);
    r->host.parameter_count = analytic_model_parameter_count(r->model);
    r->host.parameters = analytic_model_parameters(r->model);
    r->host.user = r->model;
    r->host.regenerate = host_regenerate;
    r->host.references = host_references;
    r->host.simulate = host_simulate;
    r->host.thread_safe = 1;
    r->next = g_hosts;
    g_hosts = r;
  }
  pthread_mutex_unlock(&g_hosts_lock);
  analytic_model_destroy(m); /* an equal host existed, or no memory for a new one */
  if (!r && error) *error = "analytic host: out of memory";
  return r ? &r->host : NULL;
}

#if defined(__GNUC__) || defined(__clang__)
/* Unloading ends the hosts' lifetime (cadinterp_builder.h), so their memory goes with it. */
__attribute__((destructor)) static void release_hosts(void) {
  host_record* r = g_hosts;
  g_hosts = NULL;
  while (r) {
    host_record* next = r->next;
    analytic_model_destroy(r->model);
    free(r);
    r = next;
  }
}
#endif
